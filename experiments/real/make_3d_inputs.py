#!/usr/bin/python3
"""Makes the inputs of the 3D real experiments from CGAL's package data
(data/scans/cgal/, fetched by scripts/fetch_scans.sh) into data/real/<case>/ (not committed).
Deterministic: fixed seeds, no other randomness.

Per case, in data/real/<case>/:
  truth.mha          the true object, uint8 0/1, on the image grid (the ground truth mask)
  image.mha          the CT-like image, int16 HU, zlib MetaImage with the real spacing
  truth_300.off      the true surface decimated to ~300 vertices (liver: `dsnake template --mask truth.mha`;
                     femur: femur.off decimated, see below):
                     the template of the fixed-point runs
  template.off       truth_300.off deformed by T (below): the template of the registrations
  reference.mha      the atlas: the CT-like image resampled through T^-1, in which template.off sits
                     on its object (template.reference_image; elastix's moving image), int16 HU
  reference_truth.mha  the atlas of the fixed-point runs: the noise-free image with a third noise
                     realisation, in which truth_300.off sits on its object
  inputs.json        the numbers below, as made

The deformation T (about the volume centroid c of truth_300.off): anisotropic scaling
S = diag(1.10, 0.91, 1.07) along the world axes, then a twist about the template's long axis a
(the principal axis of its volume moments, through c): a rotation by theta(s) = 15 deg x s / L about a,
s = a . (S (x - c)), L the extent of the scaled template along a (so the two ends turn 15 deg
against each other). T is a diffeomorphism with an exact inverse (the rotation keeps s).

The CT-like image: piecewise constant HU per tissue, Gaussian blur sigma 1 mm (the scanner's
point spread), additive Gaussian noise, rounded to int16. The reference image is the same
noise-free blurred volume resampled through T^-1 (linear interpolation) with its own noise
realisation (another seed), as an atlas scanned on another day would have.

liver (CGAL's liver.inr.gz: 438 x 353 x 165 voxels of 0.617 x 0.617 x 1.333 mm; labels 255 the
  liver, 127 a 160 ml neighbouring organ, 85 a 9 ml one in contact with the liver): the grid as is.
  Truth: label 255. HU: liver 60, label 127 35 (kidney-like), label 85 10 (gallbladder-like bile),
  other soft tissue 25 inside the body; the body is the union of an elliptic cylinder (semi-axes
  0.46 x 0.44 of the grid's extent, axis along z, centred) and the liver widened by 12 mm, its outer
  8 mm subcutaneous fat (-100 HU); air (-1000 HU) outside it. Noise sigma 12 HU.
femur (CGAL's femur.off: a genus-2 closed mesh of 0.40 x 0.34 x 1.0 units, a proximal femur): scaled
  x100 (mm) about its bounding box centre and turned 180 deg about y (so that the head is superior),
  so the bone part is 40 x 34 x 100 mm; voxelised by a 0-iteration
  `dsnake run` (result_mask; its 25 voxels of enclosed cavities, remnants of the tunnels below,
  filled) on a grid of 0.7 x 0.7 x 0.8 mm spanning the bone plus 30 mm on every side. HU: bone 700, muscle 40 inside a thigh-like elliptic cylinder (semi-axes: the bone's
  half-extents + 22 mm, axis along z), its outer 6 mm fat (-100), air (-1000) outside. Noise sigma 20 HU.
  Its genus 2 comes from two tunnels only 0.2-0.3 mm wide at this scale (found by voxelising at
  0.12 mm: Euler characteristic of the solid -1, at 0.25 mm already 1), invisible on any CT grid:
  the truth mask is genus 0, so truth_300.off is femur.off decimated by topology-keeping edge
  collapses (decimate() below: Euler characteristic -2, no self-intersection), not a mask's surface.

Usage: make_3d_inputs.py DSNAKE_BINARY [REPO_ROOT] [CASE ...]   (cases: liver femur; default both)
"""
import gzip
import json
import os
import subprocess
import sys
import tempfile
import zlib

import numpy as np
from scipy import ndimage as ndi

SCALE = (1.10, 0.91, 1.07)
TWIST_DEG = 15.0
VERTICES = 300


# ---------------------------------------------------------------- images (arrays are [z, y, x])

def write_mha(path, vol, spacing, origin=(0.0, 0.0, 0.0)):
    """A zlib-compressed 3D MetaImage, LPS identity direction (atomically)."""
    types = {np.dtype(np.uint8): "MET_UCHAR", np.dtype(np.int16): "MET_SHORT", np.dtype(np.float32): "MET_FLOAT"}
    data = zlib.compress(np.ascontiguousarray(vol).tobytes(), 6)
    nz, ny, nx = vol.shape
    head = ("ObjectType = Image\nNDims = 3\nBinaryData = True\nBinaryDataByteOrderMSB = False\n"
            f"CompressedData = True\nCompressedDataSize = {len(data)}\n"
            "TransformMatrix = 1 0 0 0 1 0 0 0 1\n"
            f"Offset = {origin[0]!r} {origin[1]!r} {origin[2]!r}\nCenterOfRotation = 0 0 0\n"
            "AnatomicalOrientation = RAI\n"
            f"ElementSpacing = {spacing[0]!r} {spacing[1]!r} {spacing[2]!r}\nDimSize = {nx} {ny} {nz}\n"
            f"ElementType = {types[vol.dtype]}\nElementDataFile = LOCAL\n")
    tmp = path + ".tmp"
    with open(tmp, "wb") as f:
        f.write(head.encode())
        f.write(data)
    os.replace(tmp, path)


def read_mha(path):
    """A 3D MetaImage written by dsnake convert or write_mha: (array[z, y, x], spacing, origin)."""
    raw = open(path, "rb").read()
    header, pos = {}, 0
    while True:
        end = raw.index(b"\n", pos)
        key, _, value = raw[pos:end].decode().partition("=")
        pos = end + 1
        header[key.strip()] = value.strip()
        if key.strip() == "ElementDataFile":
            break
    if header.get("TransformMatrix", "1 0 0 0 1 0 0 0 1").split() != "1 0 0 0 1 0 0 0 1".split():
        raise SystemExit(f"make_3d_inputs: {path}: expected an identity TransformMatrix")
    types = {"MET_UCHAR": np.uint8, "MET_FLOAT": np.float32, "MET_SHORT": np.int16}
    nx, ny, nz = (int(v) for v in header["DimSize"].split())
    data = raw[pos:] if header["ElementDataFile"] == "LOCAL" else open(
        os.path.join(os.path.dirname(path), header["ElementDataFile"]), "rb").read()
    if header.get("CompressedData", "False") == "True":
        data = zlib.decompress(data)
    vol = np.frombuffer(data, dtype=types[header["ElementType"]]).reshape(nz, ny, nx)
    spacing = [float(v) for v in header["ElementSpacing"].split()]
    origin = [float(v) for v in header.get("Offset", "0 0 0").split()]
    return vol, spacing, origin


def read_inr_gz(path):
    """CGAL's INRIMAGE-4 (8-bit unsigned, 256-byte header): (array[z, y, x], spacing)."""
    raw = gzip.open(path).read()
    head = raw[:256].decode(errors="replace")
    fields = dict(line.split("=", 1) for line in head.splitlines() if "=" in line)
    nx, ny, nz = int(fields["XDIM"]), int(fields["YDIM"]), int(fields["ZDIM"])
    assert fields["TYPE"] == "unsigned fixed" and fields["PIXSIZE"].startswith("8")
    spacing = [float(fields["VX"]), float(fields["VY"]), float(fields["VZ"])]
    return np.frombuffer(raw[256:], np.uint8).reshape(nz, ny, nx).copy(), spacing


def blur_mm(vol, spacing, sigma_mm):
    return ndi.gaussian_filter(vol.astype(np.float32), [sigma_mm / spacing[2], sigma_mm / spacing[1], sigma_mm / spacing[0]])


def to_hu(vol, sigma_noise, seed):
    rng = np.random.default_rng(seed)
    out = vol + rng.normal(0.0, sigma_noise, vol.shape).astype(np.float32)
    return np.clip(np.rint(out), -1024, 3071).astype(np.int16)


def elliptic_cylinder(shape, spacing, origin, centre_xy, semi_axes):
    """Voxels (all z) whose centre (x, y) lies inside the ellipse."""
    nz, ny, nx = shape
    x = origin[0] + np.arange(nx) * spacing[0]
    y = origin[1] + np.arange(ny) * spacing[1]
    e = ((x[None, :] - centre_xy[0]) / semi_axes[0]) ** 2 + ((y[:, None] - centre_xy[1]) / semi_axes[1]) ** 2 <= 1.0
    return np.broadcast_to(e[None, :, :], shape)


def body_layers(body, spacing, fat_mm):
    """(inside the body, in its outer fat layer) from the body mask."""
    depth = ndi.distance_transform_edt(body, sampling=(spacing[2], spacing[1], spacing[0]))
    return body, body & (depth <= fat_mm)


# ---------------------------------------------------------------- meshes

def read_off(path):
    tok = [t for line in open(path) for t in line.split("#")[0].split()]
    assert tok[0] == "OFF"
    nv, nf = int(tok[1]), int(tok[2])
    v = np.array(tok[4:4 + 3 * nv], float).reshape(nv, 3)
    f = np.array(tok[4 + 3 * nv:4 + 3 * nv + 4 * nf], int).reshape(nf, 4)
    assert (f[:, 0] == 3).all()
    return v, f[:, 1:]


def write_off(path, v, f):
    with open(path + ".tmp", "w") as out:
        out.write(f"OFF\n{len(v)} {len(f)} 0\n")
        for p in v:
            out.write(f"{p[0]:.17g} {p[1]:.17g} {p[2]:.17g}\n")
        for t in f:
            out.write(f"3 {t[0]} {t[1]} {t[2]}\n")
    os.replace(path + ".tmp", path)


def volume_moments(v, f):
    """Volume, centroid and second central moments of a closed outward mesh (signed tetrahedra)."""
    a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    vol6 = np.einsum("ij,ij->i", a, np.cross(b, c))
    volume = vol6.sum() / 6.0
    centroid = (vol6[:, None] * (a + b + c)).sum(0) / (24.0 * volume)
    # second moments of each tetrahedron (0, a, b, c): (vol/20) (sum_i x_i x_i^T + s s^T), s = a + b + c
    s = a + b + c
    m = np.einsum("i,ij,ik->jk", vol6 / 120.0, s, s)
    for p in (a, b, c):
        m += np.einsum("i,ij,ik->jk", vol6 / 120.0, p, p)
    cov = m / volume - np.outer(centroid, centroid)
    return volume, centroid, cov


def euler(v, f):
    edges = {tuple(sorted((t[i], t[(i + 1) % 3]))) for t in f for i in range(3)}
    return len(v) - len(edges) + len(f)


def decimate(v, f, target, max_normal_turn_deg=60.0, min_angle_deg=2.0):
    """Quadric edge-collapse decimation (Garland & Heckbert 1997) to `target` vertices that keeps
    the topology: a collapse (u, v) -> x must pass the link condition (u and v share exactly the
    two vertices opposite their edge, so the mesh stays a closed manifold of the same genus: one
    collapse removes 1 vertex, 3 edges and 2 faces), turn no surviving face's normal by more than
    `max_normal_turn_deg`, leave no face with an angle below `min_angle_deg`, and make no new face
    cross a face it shares no vertex with (so no self-intersection). Deterministic."""
    import heapq
    v = v.astype(float).copy()
    faces = [list(t) for t in f]
    alive = [True] * len(faces)
    vf = [set() for _ in range(len(v))]
    for i, t in enumerate(faces):
        for a in t:
            vf[a].add(i)
    q = np.zeros((len(v), 4, 4))
    for t in faces:
        n = np.cross(v[t[1]] - v[t[0]], v[t[2]] - v[t[0]])
        area2 = np.linalg.norm(n)
        if area2 == 0:
            continue
        p = np.append(n / area2, -np.dot(n / area2, v[t[0]]))
        for a in t:
            q[a] += area2 * np.outer(p, p)
    version = [0] * len(v)
    removed = [False] * len(v)

    def neighbours(a):
        return {b for i in vf[a] for b in faces[i] if b != a}

    def best(a, b):
        qq = q[a] + q[b]
        cands = [v[a], v[b], (v[a] + v[b]) / 2]
        try:
            x = np.linalg.solve(qq[:3, :3], -qq[:3, 3])
            if np.linalg.norm(x - (v[a] + v[b]) / 2) < 2 * np.linalg.norm(v[a] - v[b]):
                cands.insert(0, x)
        except np.linalg.LinAlgError:
            pass
        costs = [float(np.append(c, 1) @ qq @ np.append(c, 1)) for c in cands]
        k = int(np.argmin(costs))
        return max(costs[k], 0.0), cands[k]

    def valid(a, b, x):
        na, nb = neighbours(a), neighbours(b)
        shared = na & nb
        if len(shared) != 2 or len(na | nb) < 5:
            return False
        cos_turn, sin_min = np.cos(np.radians(max_normal_turn_deg)), np.sin(np.radians(min_angle_deg))
        for i in vf[a] | vf[b]:
            t = faces[i]
            if a in t and b in t:
                continue
            old = [v[c] for c in t]
            new = [x if c in (a, b) else v[c] for c in t]
            n0 = np.cross(old[1] - old[0], old[2] - old[0])
            n1 = np.cross(new[1] - new[0], new[2] - new[0])
            l1 = np.linalg.norm(n1)
            if l1 == 0 or np.dot(n0, n1) < cos_turn * np.linalg.norm(n0) * l1:
                return False
            for k in range(3):
                e1, e2 = new[(k + 1) % 3] - new[k], new[(k + 2) % 3] - new[k]
                if np.linalg.norm(np.cross(e1, e2)) < sin_min * np.linalg.norm(e1) * np.linalg.norm(e2):
                    return False
            if crosses(new, [c if c not in (a, b) else -1 for c in t], a, b):
                return False
        return True

    def crosses(tri, ids, a, b):
        """Does the triangle cross an alive face sharing none of its vertices (nor a, b)?"""
        tri = np.array(tri)
        lo, hi = tri.min(0), tri.max(0)
        cand = [i for i in np.nonzero((flo <= hi).all(1) & (fhi >= lo).all(1))[0]
                if alive[i] and not (set(faces[i]) & (set(ids) | {a, b}))]
        for i in cand:
            other = v[faces[i]]
            if tri_tri(tri, other):
                return True
        return False

    fbox = np.array([v[t] for t in faces])
    flo, fhi = fbox.min(1), fbox.max(1)

    def update_box(i):
        p = v[faces[i]]
        flo[i], fhi[i] = p.min(0), p.max(0)

    heap = []

    def push(a, b):
        a, b = min(a, b), max(a, b)
        cost, _ = best(a, b)
        heapq.heappush(heap, (cost, a, b, version[a], version[b]))

    for t in faces:
        for k in range(3):
            if t[k] < t[(k + 1) % 3]:
                push(t[k], t[(k + 1) % 3])
    count = len(v)
    while count > target and heap:
        cost, a, b, va, vb = heapq.heappop(heap)
        if removed[a] or removed[b] or va != version[a] or vb != version[b]:
            continue
        _, x = best(a, b)
        if not valid(a, b, x):
            continue
        for i in list(vf[b]):
            t = faces[i]
            if a in t:
                alive[i] = False
                for c in t:
                    vf[c].discard(i)
            else:
                t[t.index(b)] = a
                vf[a].add(i)
        vf[b] = set()
        removed[b] = True
        v[a] = x
        for i in vf[a]:
            update_box(i)
        q[a] += q[b]
        version[a] += 1
        count -= 1
        for c in neighbours(a):
            version[c] += 1
        for c in neighbours(a):
            for d in neighbours(c):
                push(c, d)
    keep = [i for i in range(len(v)) if not removed[i]]
    index = {old: new for new, old in enumerate(keep)}
    out_f = np.array([[index[c] for c in faces[i]] for i in range(len(faces)) if alive[i]])
    return v[keep], out_f


def segment_hits_triangle(p, q, tri):
    """Does the segment p q cross the triangle (Moller-Trumbore, closed)?"""
    d = q - p
    e1, e2 = tri[1] - tri[0], tri[2] - tri[0]
    h = np.cross(d, e2)
    det = np.dot(e1, h)
    if abs(det) < 1e-14:
        return False
    s = (p - tri[0]) / det
    u = np.dot(s, h)
    if u < 0 or u > 1:
        return False
    qv = np.cross(s, e1)
    w = np.dot(d, qv)
    if w < 0 or u + w > 1:
        return False
    t = np.dot(e2, qv)
    return 0 <= t <= 1


def tri_tri(t1, t2):
    """Do two triangles that share no vertex intersect (one's edge crosses the other)?"""
    for s, o in ((t1, t2), (t2, t1)):
        for k in range(3):
            if segment_hits_triangle(s[k], s[(k + 1) % 3], o):
                return True
    return False


def rasterise(v, f, shape, spacing, origin):
    """The closed mesh's interior on the grid (voxel centres; parity of the crossings along z):
    the same voxels as dsnake's result_mask, for the start Dice written to inputs.json."""
    nz, ny, nx = shape
    hits = {}
    for a, b, c in zip(v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]):
        lo, hi = np.minimum(np.minimum(a, b), c), np.maximum(np.maximum(a, b), c)
        i0, i1 = int(np.ceil((lo[0] - origin[0]) / spacing[0])), int(np.floor((hi[0] - origin[0]) / spacing[0]))
        j0, j1 = int(np.ceil((lo[1] - origin[1]) / spacing[1])), int(np.floor((hi[1] - origin[1]) / spacing[1]))
        d = (b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1])
        if i1 < i0 or j1 < j0 or d == 0:
            continue
        ii, jj = np.meshgrid(np.arange(i0, i1 + 1), np.arange(j0, j1 + 1), indexing="ij")
        ii, jj = ii.ravel(), jj.ravel()
        px, py = origin[0] + ii * spacing[0] + 1e-7, origin[1] + jj * spacing[1] + 2e-7
        l1 = ((px - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (py - a[1])) / d
        l2 = ((b[0] - a[0]) * (py - a[1]) - (px - a[0]) * (b[1] - a[1])) / d
        ok = (l1 >= 0) & (l2 >= 0) & (l1 + l2 <= 1)
        z = a[2] + l1 * (b[2] - a[2]) + l2 * (c[2] - a[2])
        for i, j, zz in zip(ii[ok], jj[ok], z[ok]):
            hits.setdefault((i, j), []).append(zz)
    mask = np.zeros(shape, bool)
    zc = origin[2] + np.arange(nz) * spacing[2]
    for (i, j), zs in hits.items():
        zs = np.sort(zs)
        for k in range(0, len(zs) - 1, 2):
            mask[(zc > zs[k]) & (zc < zs[k + 1]), j, i] = True
    return mask


def dice(a, b):
    return float(2 * (a & b).sum() / (a.sum() + b.sum()))


def rotation(axis, angle):
    """Rotation matrices (n, 3, 3) about the unit axis by the angles (n,) (Rodrigues)."""
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    s, c = np.sin(angle)[:, None, None], np.cos(angle)[:, None, None]
    return np.eye(3)[None] + s * k[None] + (1 - c) * (k @ k)[None]


class Deformation:
    """T(x) = c + R_a(theta(a . u)) u, u = S (x - c); theta(s) = twist x s / L."""

    def __init__(self, v, f):
        _, self.c, cov = volume_moments(v, f)
        w, vec = np.linalg.eigh(cov)
        a = vec[:, np.argmax(w)]
        self.a = a / np.linalg.norm(a) * (1 if a[np.argmax(np.abs(a))] > 0 else -1)
        self.S = np.array(SCALE)
        s = (self.S * (v - self.c)) @ self.a
        self.L = float(s.max() - s.min())
        self.k = np.radians(TWIST_DEG) / self.L

    def forward(self, x):
        u = self.S * (x - self.c)
        r = rotation(self.a, self.k * (u @ self.a))
        return self.c + np.einsum("nij,nj->ni", r, u)

    def inverse(self, y):
        u = y - self.c
        r = rotation(self.a, -self.k * (u @ self.a))
        return self.c + np.einsum("nij,nj->ni", r, u) / self.S


def warp_inverse(vol, spacing, origin, deform, chunk_z=8):
    """out(y) = vol(T^-1(y)): linear interpolation, nearest border value outside."""
    nz, ny, nx = vol.shape
    out = np.empty(vol.shape, np.float32)
    yy, xx = np.meshgrid(np.arange(ny), np.arange(nx), indexing="ij")
    for z0 in range(0, nz, chunk_z):
        zs = np.arange(z0, min(nz, z0 + chunk_z))
        zz = np.broadcast_to(zs[:, None, None], (len(zs), ny, nx))
        world = np.stack([origin[0] + np.broadcast_to(xx, zz.shape) * spacing[0],
                          origin[1] + np.broadcast_to(yy, zz.shape) * spacing[1],
                          origin[2] + zz * spacing[2]], -1).reshape(-1, 3)
        src = deform.inverse(world)
        idx = [(src[:, 2] - origin[2]) / spacing[2], (src[:, 1] - origin[1]) / spacing[1], (src[:, 0] - origin[0]) / spacing[0]]
        out[z0:z0 + len(zs)] = ndi.map_coordinates(vol, idx, order=1, mode="nearest").reshape(zz.shape)
    return out


# ---------------------------------------------------------------- dsnake helpers

def run(cmd):
    p = subprocess.run(cmd, check=True, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    return p.stdout.strip()


def voxelise(dsnake, mesh, shape, spacing, origin, work):
    """The mesh's interior on the grid: dsnake run's result_mask of a 0-iteration run."""
    write_mha(f"{work}/zero.mha", np.zeros(shape, np.int16), spacing, origin)
    exp = {"dimension": 3, "name": "voxelise", "image": {"file": f"{work}/zero.mha"},
           "template": {"file": os.path.abspath(mesh)}, "field": {"type": "gradient"},
           "energies": [{"type": "internal", "weight": 1.0}], "phases": [{"iterations": 0}],
           "output": {"figures": False}}
    json.dump(exp, open(f"{work}/voxelise.json", "w"))
    run([dsnake, "run", f"{work}/voxelise.json", "--out", f"{work}/voxelise", "--quiet", "-j", "1"])
    run([dsnake, "convert", f"{work}/voxelise/result_mask.nii.gz", f"{work}/mask.mha"])
    m, sp, org = read_mha(f"{work}/mask.mha")
    assert m.shape == tuple(shape) and np.allclose(sp, spacing) and np.allclose(org, origin), (m.shape, sp, org)
    return m > 0.5


def template_from_mask(dsnake, mask_path, out):
    return run([dsnake, "template", "--mask", mask_path, "--label", "1", "--vertices", str(VERTICES), "--out", out, "-j", "1"])


# ---------------------------------------------------------------- cases

def liver(dsnake, root, out, work):
    label, spacing = read_inr_gz(f"{root}/data/scans/cgal/images/liver.inr.gz")
    origin = [0.0, 0.0, 0.0]
    truth = label == 255
    write_mha(f"{out}/truth.mha", truth.astype(np.uint8), spacing, origin)
    nz, ny, nx = label.shape
    extent = [nx * spacing[0], ny * spacing[1]]
    centre = [origin[0] + (nx - 1) / 2 * spacing[0], origin[1] + (ny - 1) / 2 * spacing[1]]
    sp = (spacing[2], spacing[1], spacing[0])
    body = elliptic_cylinder(label.shape, spacing, origin, centre, [0.46 * extent[0], 0.44 * extent[1]]).copy()
    body |= ndi.distance_transform_edt(~truth, sampling=sp) <= 12.0
    body, fat = body_layers(body, spacing, 8.0)
    hu = np.full(label.shape, -1000.0, np.float32)
    hu[body] = 25.0
    hu[fat] = -100.0
    hu[label == 127] = 35.0
    hu[label == 85] = 10.0
    hu[truth] = 60.0
    info = {"grid": [nx, ny, nz], "spacing_mm": spacing, "hu": {"liver": 60, "label127": 35, "label85": 10, "soft_tissue": 25,
            "fat": -100, "air": -1000}, "body": "elliptic cylinder 0.46 x 0.44 of the extent U liver + 12 mm; fat 8 mm",
            "blur_sigma_mm": 1.0, "noise_sigma_hu": 12.0, "seeds": [20, 21, 22]}
    line = template_from_mask(dsnake, f"{out}/truth.mha", f"{out}/truth_300.off")
    return finish(out, hu, truth, spacing, origin, 12.0, (20, 21), info, line)


def femur(dsnake, root, out, work):
    v, f = read_off(f"{root}/data/scans/cgal/meshes/femur.off")
    assert euler(v, f) == -2
    v = (v - (v.min(0) + v.max(0)) / 2) * 100.0  # mm, centred at the origin
    v[:, 0], v[:, 2] = -v[:, 0], -v[:, 2]  # turned 180 deg about y: the head superior (LPS +z)
    spacing = [0.7, 0.7, 0.8]
    lo, hi = v.min(0) - 30.0, v.max(0) + 30.0
    shape_xyz = np.ceil((hi - lo) / spacing).astype(int) + 1
    origin = list(lo)
    v_scaled = f"{work}/femur_mm.off"
    write_off(v_scaled, v, f)
    shape = (shape_xyz[2], shape_xyz[1], shape_xyz[0])
    truth = ndi.binary_fill_holes(voxelise(dsnake, v_scaled, shape, spacing, origin, work))  # 25 voxels of cavities (tunnel remnants)
    write_mha(f"{out}/truth.mha", truth.astype(np.uint8), spacing, origin)
    half = (v.max(0) - v.min(0)) / 2
    body = elliptic_cylinder(shape, spacing, origin, [0.0, 0.0], [half[0] + 22.0, half[1] + 22.0]).copy()
    body, fat = body_layers(body, spacing, 6.0)
    hu = np.full(shape, -1000.0, np.float32)
    hu[body] = 40.0
    hu[fat] = -100.0
    hu[truth] = 700.0
    info = {"grid": [int(s) for s in shape_xyz], "spacing_mm": spacing, "origin_mm": [float(o) for o in origin],
            "mesh_scale": 100.0, "hu": {"bone": 700, "muscle": 40, "fat": -100, "air": -1000},
            "body": "elliptic cylinder, semi-axes bone half-extents + 22 mm; fat 6 mm",
            "blur_sigma_mm": 1.0, "noise_sigma_hu": 20.0, "seeds": [30, 31, 32]}
    # The mesh's two handles are tunnels 0.2-0.3 mm wide (at x100): no voxel grid coarser than
    # ~0.15 mm shows them, so the truth mask (and a template from it) is genus 0. The template is
    # therefore femur.off itself decimated by edge collapses that keep its topology.
    d, g = decimate(v, f, VERTICES)
    assert euler(d, g) == -2
    write_off(f"{out}/truth_300.off", d, g)
    line = f"truth_300.off: {len(d)} vertices, {len(g)} faces, Euler characteristic {euler(d, g)} (femur.off x100, decimated)"
    return finish(out, hu, truth, spacing, origin, 20.0, (30, 31), info, line)


def finish(out, hu, truth, spacing, origin, noise, seeds, info, line):
    clean = blur_mm(hu, spacing, 1.0)
    write_mha(f"{out}/image.mha", to_hu(clean, noise, seeds[0]), spacing, origin)
    v, f = read_off(f"{out}/truth_300.off")
    deform = Deformation(v, f)
    moved = deform.forward(v)
    write_off(f"{out}/template.off", moved, f)
    ref = warp_inverse(clean, spacing, origin, deform)
    write_mha(f"{out}/reference.mha", to_hu(ref, noise, seeds[1]), spacing, origin)
    write_mha(f"{out}/reference_truth.mha", to_hu(clean, noise, seeds[1] + 1), spacing, origin)
    info.update({"truth_voxels": int(truth.sum()), "truth_volume_ml": float(truth.sum() * np.prod(spacing) / 1000),
                 "truth_300": line, "truth_300_euler": euler(v, f), "deformation": {
                     "scale": list(SCALE), "twist_deg": TWIST_DEG, "centroid_mm": deform.c.tolist(),
                     "long_axis": deform.a.tolist(), "length_mm": deform.L},
                 "start_dice": {"template": dice(rasterise(moved, f, truth.shape, spacing, origin), truth),
                                "truth_300": dice(rasterise(v, f, truth.shape, spacing, origin), truth)},
                 "template_vertex_displacement_mm": {
                     "mean": float(np.linalg.norm(deform.forward(v) - v, axis=1).mean()),
                     "max": float(np.linalg.norm(deform.forward(v) - v, axis=1).max())}})
    json.dump(info, open(f"{out}/inputs.json", "w"), indent=1)
    return info


def main():
    dsnake = os.path.abspath(sys.argv[1])
    root = os.path.abspath(sys.argv[2] if len(sys.argv) > 2 else os.path.join(os.path.dirname(__file__), "..", ".."))
    cases = sys.argv[3:] or ["liver", "femur"]
    for case in cases:
        out = os.path.join(root, "data", "real", case)
        os.makedirs(out, exist_ok=True)
        with tempfile.TemporaryDirectory(prefix=f"make3d-{case}-") as work:
            info = {"liver": liver, "femur": femur}[case](dsnake, root, out, work)
        print(f"make_3d_inputs: {out}: {info['truth_300']}; start Dice {info['start_dice']}; template moved {info['template_vertex_displacement_mm']['mean']:.2f} mm "
              f"mean, {info['template_vertex_displacement_mm']['max']:.2f} max")


if __name__ == "__main__":
    main()
