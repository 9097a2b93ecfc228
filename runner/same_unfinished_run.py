"""Whether an output file holds an unfinished run of the scene and settings asked for now: one `grains resume`
should continue rather than a new run replace it. runner/main.sh asks before it runs a scene again.

    python runner/same_unfinished_run.py GRAINS FILE.h5 SCENE.toml [KEY=VALUE ...]

Exit status 0 when FILE.h5 is a grains output whose run neither ended (status 'complete...') nor failed (status
'failed...', which a resume would repeat), and whose stored scene is SCENE with the KEY=VALUE overrides as `grains
check` resolves them (run_reuse.difference: the thread count aside); 1 otherwise (no such file, another kind of
file, a finished run, other settings, a scene grains refuses). Prints nothing: grains says the rest.
"""
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import run_files  # noqa: E402
import run_reuse  # noqa: E402
import scene_check  # noqa: E402


def same_unfinished_run(grains, h5, scene_file, overrides):
    found = run_files.run_status(h5)
    if found is None or found.startswith(("complete", "failed")):
        return False
    try:
        now = scene_check.resolve(grains, scene_file, overrides)
    except scene_check.SceneError:   # grains run says what it refuses
        return False
    return run_reuse.difference(now, h5) is None


if __name__ == "__main__":
    if len(sys.argv) < 4:
        print(f"usage: {Path(sys.argv[0]).name} GRAINS FILE.h5 SCENE.toml [KEY=VALUE ...]", file=sys.stderr)
        sys.exit(2)
    grains, h5, scene_file, *overrides = sys.argv[1:]
    sys.exit(0 if same_unfinished_run(grains, h5, scene_file, overrides) else 1)
