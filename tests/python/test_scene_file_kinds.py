"""What grains reads a scene (and a particle table) from: a regular file or a pipe. `grains check /dev/zero` read
until memory ran out and then said "out of memory"; a device is refused up front naming the path and what is
allowed, and so is a scene file past 16 MiB (particles.file has no size limit, but a device is refused there too).
Pipes (`<(cat scene.toml)`) work as they did. Each grains here runs with its address space capped, so that a
build that reads without end fails fast instead of taking the machine's memory."""
import os
import resource
import subprocess
import threading

import pytest

LIMIT = 16 << 20   # engine/io/scene.hpp, scene_file_limit
ALLOWED = "a scene is a TOML file (a regular file or a pipe) of at most 16 MiB"


def capped():
    resource.setrlimit(resource.RLIMIT_AS, (4 << 30, 4 << 30))


def grains(*args, shell=False):
    return subprocess.run(args[0] if shell else [str(a) for a in args], capture_output=True, text=True, shell=shell,
                          executable="/bin/bash" if shell else None, preexec_fn=capped, timeout=120)


@pytest.mark.parametrize("command", ["check", "run"])
def test_a_device_as_the_scene_is_refused_naming_it(grains_bin, tmp_path, command):
    r = grains(grains_bin, command, "/dev/zero", *(["--out", tmp_path / "z.h5"] if command == "run" else []))
    assert r.returncode == 1, r.stderr
    assert f"error: scene file '/dev/zero' is a character device: {ALLOWED}" in r.stderr, r.stderr
    assert not list(tmp_path.iterdir())


def test_a_scene_file_past_the_limit_is_refused_with_its_size(grains_bin, root, tmp_path):
    big = tmp_path / "big.toml"
    text = (root / "models" / "gas.toml").read_text()
    big.write_text(text + "#" * (LIMIT - len(text.encode())) + "\n")   # one byte past
    r = grains(grains_bin, "check", big)
    assert r.returncode == 1 and f"scene file '{big}' holds {LIMIT + 1} bytes: {ALLOWED} ({LIMIT} bytes)" in r.stderr, r.stderr
    big.write_text(text + "#" * (LIMIT - len(text.encode()) - 1) + "\n")   # at the limit: read
    assert grains(grains_bin, "check", big).returncode == 0


def test_a_pipe_is_read_as_a_scene_and_an_endless_one_is_refused_at_the_limit(grains_bin, root):
    scene = root / "models" / "gas.toml"
    r = grains(f"'{grains_bin}' check <(cat '{scene}')", shell=True)
    assert r.returncode == 0 and "grains run` takes 5000 steps" in r.stdout, r.stderr
    r = grains(f"'{grains_bin}' check <(yes '# a comment')", shell=True)
    assert r.returncode == 1 and f"holds more than {LIMIT} bytes: {ALLOWED}" in r.stderr, r.stderr


def _scene_reading(root, folder, particles):
    """collision-2d with its two disks read from `particles`."""
    text = (root / "models" / "collision-2d.toml").read_text()
    text = text.replace('layout = "list"', f'layout = "file"\nfile = "{particles}"')
    text = text.replace("positions = [[-0.6, 0.0], [0.6, 0.0]]\n", "").replace('velocity = "list"\n', "")
    text = text.replace("velocities = [[0.5, 0.0], [-0.5, 0.0]]\n", "").replace("diameter = 1.0\nmass = 1.0\n", "")
    scene = folder / "scene.toml"
    scene.write_text(text)
    return scene


def test_a_device_as_particles_file_is_refused_and_a_pipe_is_read(grains_bin, root, tmp_path):
    r = grains(grains_bin, "check", _scene_reading(root, tmp_path, "/dev/zero"))
    assert r.returncode == 1, r.stderr
    assert ("particles.file: '/dev/zero' is a character device: name a file of particle rows (a regular file or a pipe)"
            in r.stderr), r.stderr
    fifo = tmp_path / "disks.fifo"
    os.mkfifo(fifo)
    writer = threading.Thread(target=lambda: fifo.write_text("-0.6 0 1 1 0.5 0\n0.6 0 1 1 -0.5 0\n"), daemon=True)
    writer.start()
    r = grains(grains_bin, "check", _scene_reading(root, tmp_path, fifo))
    writer.join(timeout=10)
    assert r.returncode == 0 and "2 particles" in r.stdout, r.stdout + r.stderr
