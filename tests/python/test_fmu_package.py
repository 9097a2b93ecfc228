"""The .fmu archives as files: fmpy's validation, the standard layout, a self-contained binary that
exports only FMI functions, and reference results that the FMU reproduces."""
import csv
import subprocess
import tomllib
import zipfile

import fmpy
import fmpy.validation
import numpy as np
import pytest

from fmu_host import extracted, fmu_path

MODELS = ["aggregation", "collision", "consolidation"]
VERSIONS = [2, 3]
PLATFORM = {2: "linux64", 3: "x86_64-linux"}

# What the FMU binary may load: the C library and the C++/GCC runtimes (libgomp is GCC's OpenMP
# runtime, installed with libstdc++ and libgcc wherever GCC-built C++ runs).
ALLOWED_LIBRARIES = {"libc.so.6", "libm.so.6", "libstdc++.so.6", "libgcc_s.so.1", "libgomp.so.1",
                     "ld-linux-x86-64.so.2", "libpthread.so.0", "libdl.so.2", "librt.so.1"}

FMI2_FUNCTIONS = """GetTypesPlatform GetVersion SetDebugLogging Instantiate FreeInstance SetupExperiment
EnterInitializationMode ExitInitializationMode Terminate Reset GetReal GetInteger GetBoolean GetString SetReal
SetInteger SetBoolean SetString GetFMUstate SetFMUstate FreeFMUstate SerializedFMUstateSize SerializeFMUstate
DeSerializeFMUstate GetDirectionalDerivative EnterEventMode NewDiscreteStates EnterContinuousTimeMode
CompletedIntegratorStep SetTime SetContinuousStates GetDerivatives GetEventIndicators GetContinuousStates
GetNominalsOfContinuousStates SetRealInputDerivatives GetRealOutputDerivatives DoStep CancelStep GetStatus
GetRealStatus GetIntegerStatus GetBooleanStatus GetStringStatus""".split()
FMI3_TYPES = "Float32 Float64 Int8 UInt8 Int16 UInt16 Int32 UInt32 Int64 UInt64 Boolean String Binary Clock".split()
FMI3_FUNCTIONS = """GetVersion SetDebugLogging InstantiateModelExchange InstantiateCoSimulation
InstantiateScheduledExecution FreeInstance EnterInitializationMode ExitInitializationMode EnterEventMode Terminate
Reset GetNumberOfVariableDependencies GetVariableDependencies GetFMUState SetFMUState FreeFMUState
SerializedFMUStateSize SerializeFMUState DeserializeFMUState GetDirectionalDerivative GetAdjointDerivative
EnterConfigurationMode ExitConfigurationMode GetIntervalDecimal GetIntervalFraction GetShiftDecimal GetShiftFraction
SetIntervalDecimal SetIntervalFraction SetShiftDecimal SetShiftFraction EvaluateDiscreteStates UpdateDiscreteStates
EnterContinuousTimeMode CompletedIntegratorStep SetTime SetContinuousStates GetContinuousStateDerivatives
GetEventIndicators GetContinuousStates GetNominalsOfContinuousStates GetNumberOfEventIndicators
GetNumberOfContinuousStates EnterStepMode GetOutputDerivatives DoStep ActivateModelPartition""".split() + \
    [f"{op}{t}" for t in FMI3_TYPES for op in ("Get", "Set")]


@pytest.fixture(scope="module", params=[(m, v) for m in MODELS for v in VERSIONS], ids=lambda p: f"{p[0]}-fmi{p[1]}")
def fmu(request, grains_bin):
    model, version = request.param
    path = fmu_path(model, version)
    assert path.exists(), f"{path} is missing: the build makes it (target `fmus`)"
    return model, version, path


def test_fmpy_validation_finds_no_problem(fmu):
    _, _, path = fmu
    assert fmpy.validation.validate_fmu(str(path)) == []


def test_archive_has_the_standard_layout(fmu, root):
    model, version, path = fmu
    names = set(zipfile.ZipFile(path).namelist())
    md = fmpy.read_model_description(str(path))
    assert md.fmiVersion == f"{version}.0"
    binary = f"binaries/{PLATFORM[version]}/{md.coSimulation.modelIdentifier}.so"
    fork_guard = f"binaries/{PLATFORM[version]}/grains_fork_guard.so"
    for required in ["modelDescription.xml", binary, fork_guard, "resources/scene.toml", "documentation/index.html",
                     f"extra/org.fmi-standard.fmi-ls-ref/{model}_ref.csv",
                     f"extra/org.fmi-standard.fmi-ls-ref/{model}_ref.opt",
                     "extra/org.fmi-standard.fmi-ls-ref/fmi-ls-manifest.xml"]:
        assert required in names
    assert zipfile.ZipFile(path).read("resources/scene.toml").decode() == (root / "models" / f"{model}.toml").read_text()


def binary_of(path, version):
    md = fmpy.read_model_description(str(path))
    return f"{extracted(path)}/binaries/{PLATFORM[version]}/{md.coSimulation.modelIdentifier}.so"


def fork_guard_of(path, version):
    return f"{extracted(path)}/binaries/{PLATFORM[version]}/grains_fork_guard.so"


# Scene keys with a dimension, by the packaged scenes that expose them: a host must see the grains' diameter or the
# adhesion's force with their units, not as pure numbers.
DIMENSIONED_PARAMETERS = {
    "aggregation": {"particles.diameter": "m", "particles.density": "kg/m^3", "contact.duration": "s"},
    "collision": {"particles.diameter": "m", "contact.duration": "s"},
    "consolidation": {"particles.diameter_max": "m", "particles.diameter_min": "m", "particles.density": "kg/m^2",
                      "adhesion.force": "N", "adhesion.stiffness": "N/m", "adhesion.range": "m"},
}
PURE_NUMBERS = {"contact.restitution", "friction.coefficient", "gravity.softening", "time.steps_per_contact",
                "particles.solid_fraction", "adhesion.restitution", "contact.overlap_limit"}


# What a host reads before stepping: a step that is not a whole number of dt is taken in equal steps (not with one
# shorter step), and the consolidation FMU runs no preparation or programme (not the type-2 aggregation and the
# stepwise loading of `grains consolidate`).
def test_documentation_states_how_a_communication_step_is_taken(fmu):
    _, _, path = fmu
    page = zipfile.ZipFile(path).read("documentation/index.html").decode()
    assert "ceil(h / dt) equal steps" in page
    assert "shorter step" not in page


def test_a_cell_scenes_description_says_the_fmu_runs_no_programme(fmu):
    model, _, path = fmu
    description = fmpy.read_model_description(str(path)).description
    says = "runs no preparation or programme" in description and "input cell.pressure" in description
    assert says == (model == "consolidation")


def test_scene_parameters_declare_their_units(fmu):
    model, _, path = fmu
    variables = {v.name: v for v in fmpy.read_model_description(str(path)).modelVariables}
    declared = {name: variables[name].unit for name in DIMENSIONED_PARAMETERS[model] if name in variables}
    assert declared == {name: unit for name, unit in DIMENSIONED_PARAMETERS[model].items() if name in variables}
    assert len(declared) >= 2, f"{model}: the packaged scene exposes fewer of these keys than expected: {sorted(variables)}"
    for name in PURE_NUMBERS & variables.keys():
        assert variables[name].unit in (None, ""), f"{name} is a pure number, declared {variables[name].unit}"


def reference_units(grains_bin, dimension):
    """Each scene key's SI unit for disks (2) or spheres (3) as the scene reference's unit column gives it ("" for a
    pure number, text or a switch)."""
    text = subprocess.run([grains_bin, "scene-reference"], capture_output=True, text=True, check=True).stdout
    units, section = {}, None
    for line in text.splitlines():
        if line.startswith("## ["):
            section = line[len("## ["):-1]
        elif section and line.startswith("| `"):
            key, _, unit = (cell.strip() for cell in line.strip("|").split(" | ")[:3])
            if "(3D)" in unit:
                unit = dict(reversed(part.rsplit(" ", 1)) for part in unit.split(", "))[f"({dimension}D)"]
            units[f"{section}.{key.strip('`')}"] = "" if unit == "1" else unit
    return units


def test_every_variable_named_after_a_scene_key_declares_the_scene_references_unit(fmu, grains_bin):
    """Every key, not only those DIMENSIONED_PARAMETERS names: the parameters, controls and inputs of the packaged
    scenes take their units from the scene schema, as the reference does."""
    _, _, path = fmu
    variables = fmpy.read_model_description(str(path)).modelVariables
    dimension = tomllib.loads(zipfile.ZipFile(path).read("resources/scene.toml").decode())["scene"].get("dimension", 3)
    units = reference_units(grains_bin, dimension)
    assert units["particles.density"] == ("kg/m^2" if dimension == 2 else "kg/m^3")
    named = [v for v in variables if v.name in units]
    assert len(named) >= 8
    assert {v.name: v.unit or "" for v in named} == {v.name: units[v.name] for v in named}


@pytest.mark.parametrize("library", [binary_of, fork_guard_of], ids=["binary", "fork_guard"])
def test_binary_needs_only_the_c_and_cxx_runtimes(fmu, library):
    _, version, path = fmu
    dynamic = subprocess.run(["readelf", "-d", library(path, version)], capture_output=True, text=True, check=True).stdout
    needed = {line.split("[")[1].split("]")[0] for line in dynamic.splitlines() if "(NEEDED)" in line}
    assert needed, "readelf found no dependencies at all (not a dynamic library?)"
    assert needed <= ALLOWED_LIBRARIES, f"not allowed: {needed - ALLOWED_LIBRARIES}"
    assert not any(bad in " ".join(needed) for bad in ("hdf5", "sundials", "fmt", "curl", "ssl"))


# The newest symbol versions the README promises the FMUs need (Debian 12's build: glibc 2.34, GCC 11's libstdc++).
NEWEST_VERSIONS = {"GLIBC": (2, 34), "GLIBCXX": (3, 4, 29), "CXXABI": (1, 3, 13)}


def snapshots_of(path, version):
    return f"{extracted(path)}/binaries/{PLATFORM[version]}/grains_snapshots.so"


@pytest.mark.parametrize("library", [binary_of, fork_guard_of, snapshots_of], ids=["binary", "fork_guard", "snapshots"])
def test_binary_needs_no_symbol_newer_than_glibc_2_34_and_gcc_11(fmu, library):
    """std::hypot binds GLIBC_2.35 (glibc versioned hypot anew then), which RHEL 9, named by the README, lacks; the
    list of libraries above cannot see a symbol's version."""
    _, version, path = fmu
    listing = subprocess.run(["readelf", "-V", "-W", library(path, version)], capture_output=True, text=True,
                             check=True).stdout
    needs = listing.split("Version needs section")[1] if "Version needs section" in listing else ""
    found = {}
    for word in needs.split():
        if "_" in word and word.split("_")[-1][:1].isdigit():
            family, number = word.rsplit("_", 1)
            found.setdefault(family, []).append(tuple(int(x) for x in number.split(".")))
    assert "GLIBC" in found, listing
    for family, newest in NEWEST_VERSIONS.items():
        too_new = [v for v in found.get(family, []) if v > newest]
        assert not too_new, f"{family} versions newer than {newest}: {sorted(too_new)}"


def test_fork_guard_stays_loaded_and_exports_nothing(fmu):
    """The FMU binary finds an already loaded guard by its SONAME; -z nodelete keeps it loaded, with its fork handler."""
    _, version, path = fmu
    dynamic = subprocess.run(["readelf", "-d", fork_guard_of(path, version)], capture_output=True, text=True,
                             check=True).stdout
    assert "Library soname: [grains_fork_guard.so]" in dynamic
    assert any("(FLAGS_1)" in line and "NODELETE" in line for line in dynamic.splitlines()), dynamic
    symbols = subprocess.run(["nm", "-D", "--defined-only", fork_guard_of(path, version)], capture_output=True,
                             text=True, check=True).stdout
    assert symbols.strip() == "", symbols


def test_binary_exports_every_fmi_function_and_nothing_else(fmu):
    _, version, path = fmu
    symbols = subprocess.run(["nm", "-D", "--defined-only", binary_of(path, version)], capture_output=True, text=True,
                             check=True).stdout
    exported = {line.split()[-1] for line in symbols.splitlines() if line.split()[1] in "TtWiu"}
    expected = {f"fmi2{f}" for f in FMI2_FUNCTIONS} | {f"fmi3{f}" for f in FMI3_FUNCTIONS}
    assert expected <= exported, f"missing: {sorted(expected - exported)}"
    assert all(s.startswith(("fmi2", "fmi3")) for s in exported), sorted(s for s in exported if not s.startswith("fmi"))


def test_reference_results_are_reproduced_exactly(fmu):
    """The FMI cross-check files packed in the FMU (written at build time by the engine, stepped as a host
    steps it) equal what fmpy gets from the packaged binary: the packaging and the host interface, not the
    physics, which the restitution sweep (test_fmu_state.py) and the runner comparisons check."""
    model, version, path = fmu
    archive = zipfile.ZipFile(path)
    options = dict(line.split(", ") for line in archive.read(
        f"extra/org.fmi-standard.fmi-ls-ref/{model}_ref.opt").decode().splitlines())
    rows = list(csv.reader(archive.read(f"extra/org.fmi-standard.fmi-ls-ref/{model}_ref.csv").decode().splitlines()))
    names, reference = rows[0], np.array(rows[1:], dtype=float)
    md_outputs = [v.name for v in fmpy.read_model_description(str(path)).modelVariables
                  if v.causality == "output" and not v.dimensions and not v.name.endswith("_seconds")]
    assert names == ["time"] + md_outputs
    result = fmpy.simulate_fmu(str(path), start_time=float(options["StartTime"]), stop_time=float(options["StopTime"]),
                               output_interval=float(options["StepSize"]), output=md_outputs)
    assert len(result) == len(reference)
    for j, name in enumerate(md_outputs, start=1):
        np.testing.assert_array_equal(result[name], reference[:, j], err_msg=name)
