"""Checkpoint files by field name in the engine's order (format 5), and the files written
before it (format 4: the arrays in user order; formats 2-3: prefixed keys and a row of
scalars) read into the same state: a restart from any of them continues
bit-identically."""

import numpy as np
import pytest

from demcal.errors import ConfigError

from test_pour import pour

_OLD_PREFIX = {"bodies": "b_", "spheres": "s_", "pairs": "p_", "walls": "q_"}
_OLD_FIELD = {("pairs", "other"): "nbr", ("walls", "other"): "wid"}


def _as_format_4(new, old):
    """Rewrite a format-5 checkpoint ``new`` as format 4 (``old``): the arrays put in
    user order, as ``save_checkpoint`` did before reading the state stopped reordering
    the engine (``perm_*``: engine index -> user index)."""
    with np.load(new) as z:
        assert not z["user_view"]      # format 5 keeps the engine's order
        out = {key: z[key] for key in z.files if key != "user_view"}
    out["version"] = np.asarray(4)
    if "perm_b" in out:
        inv_b, inv_s = np.argsort(out["perm_b"]), np.argsort(out["perm_s"])
        counts = np.diff(out["bodies.start"])[inv_b]
        for key in out:
            if key.startswith("bodies.") and key != "bodies.start":
                out[key] = out[key][inv_b]
            elif key.startswith("spheres."):
                out[key] = out[key][inv_s]
        out["bodies.start"] = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
        out["spheres.body"] = out["perm_b"][out["spheres.body"]]
        if "old_of_new" in out:        # the renumbering the next rebuild carries through
            out["carry_engine"] = out["old_of_new"]
        out["old_of_new"] = inv_s if "carry_engine" not in out else out["carry_engine"][inv_s]
    np.savez(old, **out)


def _as_format_3(new, old):
    """Rewrite a format-4 checkpoint ``new`` as format 3 (``old``): the layout
    ``Simulation.save_checkpoint`` wrote before issue 18."""
    with np.load(new) as z:
        out = {}
        for key in z.files:
            name, _, field = key.partition(".")
            if name in _OLD_PREFIX:
                out[_OLD_PREFIX[name] + _OLD_FIELD.get((name, field), field)] = z[key]
        out["scalars"] = np.array([float(z[k]) for k in (
            "time", "step", "dt", "wall_travel", "escaped", "forces_valid",
            "needs_rebuild")] + [3.0, float(z["last_sort"])])
        for key in ("perm_b", "perm_s", "carry_engine", "old_of_new", "gravity", "models"):
            if key in z.files:
                out[key] = z[key]
    np.savez(old, **out)


@pytest.mark.parametrize("sorted_", [False, True])
def test_format_4_and_3_checkpoints_restart_bit_identically(backend, tmp_path, sorted_):
    def build():
        sim = pour(backend, 200, 0.03, fill=2.0)
        if sorted_:
            sim.sort_threshold, sim.sort_interval = 0, 40
        sim.gravity[:] = (0.0, 0.0, -80.0)
        return sim

    a = build()
    a.run(steps=2500)
    a.save_checkpoint(tmp_path / "new.npz")
    with np.load(tmp_path / "new.npz") as z:
        assert int(z["version"]) == 5 and "bodies.pos" in z.files and "pairs.hist" in z.files
        assert bool(z["user_view"]) is False and ("perm_b" in z.files) == sorted_
    _as_format_4(tmp_path / "new.npz", tmp_path / "v4.npz")
    _as_format_3(tmp_path / "v4.npz", tmp_path / "old.npz")
    a.run(steps=500)
    for name in ("new.npz", "v4.npz", "old.npz"):
        b = build()
        b.load_checkpoint(tmp_path / name)
        b.run(steps=500)
        for field in ("positions", "velocities", "angular_momenta"):
            assert np.array_equal(getattr(a.state, field), getattr(b.state, field)), field
        for x, y in zip(a.contacts(), b.contacts()):
            assert np.array_equal(x, y)


def test_a_file_that_is_no_checkpoint_is_one_sentence(backend, tmp_path):
    np.savez(tmp_path / "x.npz", a=np.zeros(3))
    sim = pour(backend, 10, 0.03)
    with pytest.raises(ConfigError, match="not a demcal checkpoint"):
        sim.load_checkpoint(tmp_path / "x.npz")
    with pytest.raises(ConfigError, match="cannot read checkpoint"):
        sim.load_checkpoint(tmp_path / "missing.npz")
