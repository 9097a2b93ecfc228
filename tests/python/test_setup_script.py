"""runner/setup.sh, which both of the README's commands source: what it asks apt for on a fresh machine."""
import os
import subprocess


def _fake(bin_dir, name, body):
    path = bin_dir / name
    path.write_text("#!/bin/sh\n" + body + "\n")
    path.chmod(0o755)


def test_debian_python_without_venv_gets_python3_venv(root, tmp_path):
    """A fresh Debian 12 has python3 without python3-venv (no ensurepip); setup.sh left python3-venv out whenever
    a python3 was on the PATH, and `python3 -m venv` then failed, so `bash runner/main.sh` stopped there."""
    fakes = tmp_path / "bin"
    fakes.mkdir()
    asked = tmp_path / "apt-get.args"
    _fake(fakes, "dpkg-query", 'case "$*" in *python3-venv*) exit 1;; *) echo "install ok installed";; esac')
    _fake(fakes, "apt-get", f'echo "$@" >> {asked}')
    _fake(fakes, "id", "echo 0")   # as root: no sudo
    script = f'source "{root}/runner/setup.sh"; grains_install_system'
    env = dict(os.environ, PATH=f"{fakes}:{os.environ['PATH']}")

    _fake(fakes, "python3", 'case "$*" in *ensurepip*) exit 1;; *) exit 0;; esac')   # Debian's, without venv
    r = subprocess.run(["bash", "-c", script], env=env, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert "install -y -q python3-venv" in asked.read_text(), asked.read_text()

    asked.unlink()
    _fake(fakes, "python3", "exit 0")   # a python3 that can make environments: nothing to install
    r = subprocess.run(["bash", "-c", script], env=env, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert not asked.exists(), asked.read_text()
