# dsnake.field(), dsnake.energy(), dsnake.schema() and dsnake.sweep().
import json

import numpy as np
import pytest

import dsnake


def disc_image(n=48, radius=12.0):
    y, x = np.mgrid[0:n, 0:n]
    return dsnake.Image(((x - n / 2) ** 2 + (y - n / 2) ** 2 < radius ** 2).astype(np.float32) * 100)


def circle(n=24, radius=8.0, centre=24.0):
    a = np.linspace(0, 2 * np.pi, n, endpoint=False)
    return np.stack([centre + radius * np.cos(a), centre + radius * np.sin(a)], axis=1)


def test_a_gvf_field_on_the_images_grid():
    f = dsnake.field(disc_image(), "gvf", mu=0.2)
    assert f.shape == (48, 48, 2) and f.dtype == np.float32
    assert np.isfinite(f).all() and np.abs(f).max() > 0
    # Outside the disc on its right (x = 40), the field points back towards the edge (-x).
    assert f[24, 40, 0] < 0


def test_every_field_type_is_documented():
    for name in ("gvf", "vfc"):
        assert "\n" + name in dsnake.field.__doc__


def test_field_errors_name_the_key():
    with pytest.raises(dsnake.InputError, match="field.muu"):
        dsnake.field(disc_image(), "gvf", muu=0.2)
    with pytest.raises(dsnake.InputError, match="field.type"):
        dsnake.field(disc_image(), "nosuch")
    with pytest.raises(dsnake.InputError, match="argument 'image'"):
        dsnake.field(np.zeros((4, 4)))


def test_the_internal_energy_value_and_propose():
    q = circle()
    e = dsnake.energy("internal", q, alpha=0.5)
    assert e.value(q) >= 0
    moved = e.propose(q)
    assert moved.shape == q.shape and np.isfinite(moved).all()
    # The membrane pulls a circle's vertices inwards, towards its centre.
    assert np.linalg.norm(moved - 24, axis=1).mean() < np.linalg.norm(q - 24, axis=1).mean()


def test_the_external_energy_reads_the_images_field():
    q = circle(radius=14.0)
    e = dsnake.energy("external", q, image=disc_image(), field={"type": "gvf"})
    moved = e.propose(q)
    assert np.linalg.norm(moved - 24, axis=1).mean() < 14.0  # drawn in to the disc's edge (12)


def test_energy_errors():
    q = circle()
    with pytest.raises(dsnake.InputError, match="energy.alphaa"):
        dsnake.energy("internal", q, alphaa=1)
    e = dsnake.energy("internal", q)
    with pytest.raises(dsnake.InputError, match="argument 'q'"):
        e.value(q[:5])
    with pytest.raises(dsnake.InputError, match="argument 'q'.*float64"):
        e.value(q.astype(np.float32))
    with pytest.raises(dsnake.InputError, match="argument 'q'.*C-contiguous"):
        e.value(np.asfortranarray(q))
    bad = q.copy()
    bad[3, 1] = np.nan
    with pytest.raises(dsnake.InputError, match="argument 'q'.*NaN"):
        e.propose(bad)


def test_an_atlas_energy_takes_the_reference_image():
    q = circle(radius=12.0)
    atlas = disc_image()  # the template lies on its disc's edge here
    with pytest.raises(dsnake.InputError, match="argument 'reference'.*needs a reference image"):
        dsnake.energy("patch", q, image=atlas)
    with pytest.raises(dsnake.InputError, match="argument 'reference'.*dsnake.Image"):
        dsnake.energy("patch", q, image=atlas, reference=atlas.array)
    # On the atlas itself every patch matches where it is: no move.
    still = dsnake.energy("patch", q, image=atlas, reference=atlas).propose(q)
    np.testing.assert_allclose(still, q, atol=1e-9)
    # A scan whose disc is the atlas's moved 2 mm along +x: every vertex follows along x, up to the
    # default step (the sampling step, 1 mm), and none across it on average.
    scan = dsnake.Image(np.roll(atlas.array, 2, axis=1).copy())
    move = dsnake.energy("patch", q, image=scan, reference=atlas).propose(q) - q
    assert (move[:, 0] > 0.3).all() and (move[:, 0] <= 1 + 1e-9).all()
    assert abs(move[:, 1].mean()) < 1e-9


def test_every_energy_type_is_documented():
    assert "internal" in dsnake.energy.__doc__ and "alpha" in dsnake.energy.__doc__


def test_the_schema():
    schema = dsnake.schema()
    assert schema["$schema"].startswith("https://json-schema.org/")
    assert "energies" in json.dumps(schema["$defs"])


def test_a_sweep(tmp_path, default_result):
    config = dict(default_result.config)
    (tmp_path / "base.json").write_text(json.dumps(config))
    (tmp_path / "sweep.json").write_text(json.dumps(
        {"base": "base.json", "grid": {"phases[0].iterations": [3, 6]}}))
    table = dsnake.sweep(str(tmp_path / "sweep.json"), str(tmp_path / "out"), jobs=2)
    rows = table.to_dict("records") if hasattr(table, "to_dict") else table
    assert len(rows) == 2
