"""The command-line runner as a user meets it: help, errors, output safety, the scene reference."""
import subprocess

import h5py


def run(grains_bin, *args, cwd=None):
    return subprocess.run([grains_bin, *map(str, args)], capture_output=True, text=True, cwd=cwd)


def test_help_lists_the_commands(grains_bin):
    r = run(grains_bin, "--help")
    assert r.returncode == 0
    for word in ("run", "check", "scene-reference"):
        assert word in r.stdout


def test_scene_reference_page_is_current(grains_bin, root):
    r = run(grains_bin, "scene-reference")
    assert r.returncode == 0
    assert r.stdout == (root / "docs" / "scene-reference.md").read_text(), \
        "docs/scene-reference.md is stale: regenerate it with `grains scene-reference > docs/scene-reference.md`"


def test_bad_scene_fails_without_clobbering_existing_output(grains_bin, root, tmp_path):
    out = tmp_path / "precious.h5"
    out.write_bytes(b"existing results")
    r = run(grains_bin, "run", root / "models" / "collision.toml", "--out", out, "--set", "contact.restitution=1.5")
    assert r.returncode != 0
    assert "contact.restitution" in r.stderr and "1.5" in r.stderr and "(0, 1]" in r.stderr
    assert out.read_bytes() == b"existing results"


def test_unknown_key_suggests_the_right_one(grains_bin, root, tmp_path):
    r = run(grains_bin, "run", root / "models" / "collision.toml", "--out", tmp_path / "x.h5",
            "--set", "contact.restitutoin=0.5")
    assert r.returncode != 0
    assert "contact.restitutoin" in r.stderr and "did you mean 'contact.restitution'" in r.stderr


def test_every_shipped_scene_validates(grains_bin, root):
    for scene in sorted((root / "models").glob("*.toml")):
        r = run(grains_bin, "check", scene)
        assert r.returncode == 0, f"{scene.name}: {r.stderr}"


def test_run_writes_summary_and_complete_file(grains_bin, root, tmp_path):
    out = tmp_path / "c.h5"
    r = run(grains_bin, "run", root / "models" / "collision-2d.toml", "--out", out, "--quiet")
    assert r.returncode == 0, r.stderr
    assert "particle-steps/s" in r.stdout and str(out) in r.stdout
    with h5py.File(out) as f:
        assert f["grains"].attrs["status"] in ("complete", b"complete")
        ke = f["observables/kinetic_energy/value"][:]
        assert ke[-1] < ke[0]   # e = 0.5: the collision dissipates
