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


def _fake_sundials_tools(fakes, log, apt_fails=False):
    """dpkg-query names Debian's SUNDIALS version; apt-get, tar and cmake only record their arguments and leave
    what the real ones would (the source tarball, its folder, the installed package's CMake file)."""
    _fake(fakes, "dpkg-query", 'echo "6.4.1+dfsg1-3"')
    _fake(fakes, "apt-get", f'echo "apt-get $*" >> {log}; ' +
          ("exit 100" if apt_fails else 'case "$*" in *"source --download-only"*) touch sundials_6.4.1+dfsg1.orig.tar.xz;; esac'))
    _fake(fakes, "tar", f'echo "tar $*" >> {log}; while [ "$1" != "-C" ]; do shift; done; mkdir -p "$2/sundials-6.4.1"')
    _fake(fakes, "cmake", f'echo "cmake $*" >> {log}; for a in "$@"; do case "$a" in -DCMAKE_INSTALL_PREFIX=*) '
          'echo "${a#*=}" > "$(dirname "$0")/prefix";; esac; done; '
          'case "$1" in --install) p="$(cat "$(dirname "$0")/prefix")"; mkdir -p "$p/lib/cmake/sundials"; '
          'touch "$p/lib/cmake/sundials/SUNDIALSConfig.cmake";; esac')


def test_setup_builds_cvode_optimised_from_debians_source(root, tmp_path):
    """Debian 12's SUNDIALS is compiled without optimisation (its packaging's -DCMAKE_C_FLAGS=-fcommon replaces -O2),
    and CVODE took three times the processor time it takes at -O2 (docs/speed.md, Consolidation): the setup builds the
    installed version's source package at -O2, once, into the build folder, where grains_build finds it."""
    fakes = tmp_path / "bin"
    fakes.mkdir()
    log = tmp_path / "calls"
    _fake_sundials_tools(fakes, log)
    build = tmp_path / "build"
    env = dict(os.environ, PATH=f"{fakes}:{os.environ['PATH']}", GRAINS_BUILD=str(build))
    script = f'source "{root}/runner/setup.sh"; grains_build_sundials'
    r = subprocess.run(["bash", "-c", script], env=env, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    calls = log.read_text()
    assert "source --download-only sundials=6.4.1+dfsg1-3" in calls, calls
    configure = next(line for line in calls.splitlines() if line.startswith("cmake -S"))
    assert "-DCMAKE_C_FLAGS=-O2 -fcommon" in configure and "-DBUILD_CVODE=OFF" not in configure, configure
    assert f"-DCMAKE_INSTALL_PREFIX={build}/sundials" in configure, configure
    assert (build / "sundials/lib/cmake/sundials/SUNDIALSConfig.cmake").exists()
    assert not (build / "sundials-source").exists(), "the source and its build are removed once installed"

    log.unlink()   # built already: nothing fetched or built again
    r = subprocess.run(["bash", "-c", script], env=env, capture_output=True, text=True)
    assert r.returncode == 0 and not log.exists(), r.stderr


def test_setup_links_the_systems_sundials_when_the_source_cannot_be_had(root, tmp_path):
    fakes = tmp_path / "bin"
    fakes.mkdir()
    log = tmp_path / "calls"
    _fake_sundials_tools(fakes, log, apt_fails=True)
    build = tmp_path / "build"
    env = dict(os.environ, PATH=f"{fakes}:{os.environ['PATH']}", GRAINS_BUILD=str(build))
    r = subprocess.run(["bash", "-c", f'source "{root}/runner/setup.sh"; grains_build_sundials'], env=env,
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert "could not build SUNDIALS" in r.stderr and "linking the system's" in r.stderr, r.stderr
    assert not (build / "sundials").exists()
    assert "cmake" not in log.read_text()
    # Not tried again at the next command (a machine without the source would pay apt's time at every one)
    calls = log.read_text()
    again = subprocess.run(["bash", "-c", f'source "{root}/runner/setup.sh"; grains_build_sundials'], env=env,
                           capture_output=True, text=True)
    assert again.returncode == 0 and "failed before" in again.stderr, again.stderr
    assert log.read_text() == calls


def test_a_build_folder_of_another_type_keeps_its_configuration(root, tmp_path):
    """README, "Checked builds": the Python suite against a sanitized RelWithDebInfo build ran runner/main.sh with that
    folder as GRAINS_BUILD, and the setup reconfigured it as a Release build (a full rebuild) and fetched SUNDIALS'
    source into it. A folder configured for another build type is now built as it is; a Release folder as before."""
    fakes = tmp_path / "bin"
    fakes.mkdir()
    log = tmp_path / "calls"
    _fake_sundials_tools(fakes, log)
    build = tmp_path / "build"
    (build / "runner").mkdir(parents=True)
    _fake(build / "runner", "grains", "exit 0")
    env = dict(os.environ, PATH=f"{fakes}:{os.environ['PATH']}", GRAINS_BUILD=str(build))
    script = f'source "{root}/runner/setup.sh"; grains_build_sundials; grains_build'
    (build / "CMakeCache.txt").write_text("CMAKE_BUILD_TYPE:STRING=RelWithDebInfo\n")
    r = subprocess.run(["bash", "-c", script], env=env, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    calls = log.read_text().splitlines()
    assert not any("apt-get" in c for c in calls), calls   # no SUNDIALS fetched into it
    assert calls[0] == f"cmake -S {root} -B {build}", calls   # configured as it was
    log.unlink()
    (build / "CMakeCache.txt").write_text("CMAKE_BUILD_TYPE:STRING=Release\n")
    r = subprocess.run(["bash", "-c", script], env=env, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    calls = log.read_text()
    assert "source --download-only" in calls and f"-B {build} -DCMAKE_BUILD_TYPE=Release -DSUNDIALS_DIR=" in calls, calls
