"""A scene and its --set overrides as the engine resolves them (`grains check`), and the engine's refusal of them in
one line: how the tools learn what a run would run, and check their options against grains' own rules."""
import re
import subprocess
import tomllib


class SceneError(Exception):
    """The engine refused the scene or an override; the message is the engine's."""


def resolve(grains, scene_file, overrides):
    """The scene with the overrides (KEY=VALUE strings) as the engine resolves them, as a dict."""
    cmd = [str(grains), "check", str(scene_file)] + [a for o in overrides for a in ("--set", o)]
    done = subprocess.run(cmd, capture_output=True, text=True)
    if done.returncode != 0:
        raise SceneError(done.stderr.strip() or f"grains check {scene_file} exited with {done.returncode}")
    return tomllib.loads(done.stdout)   # the derived values after the scene are comments


def engine_refusal(error):
    """A SceneError's message in one line: the engine's problems without its heading, numbers of more than 16 digits
    shortened (bench_fmu's --duration 1e300 asked for a time.steps of 304 digits)."""
    lines = str(error).splitlines()   # the engine's heading, then its problems, one a line
    reason = "; ".join(line.strip(" -") for line in lines[1:] or lines)
    return re.sub(r"\d{17,}", lambda m: f"{int(m.group()):.3g}", reason)
