"""FMU overhead benchmark (not a test): the default aggregation scene run by the runner and by fmpy
driving the FMI 2 and FMI 3 FMUs with a communication step of 100 internal steps (all outputs read at
every communication point), wall time ratio measured in one session, runs alternated; then the cost
of an empty fmi2DoStep / fmi3DoStep (step size 0) through fmpy.

    python runner/bench_fmu.py [--build build] [--duration T] [--repeat 2]
"""
import argparse
import math
import os
import pathlib
import resource
import sys
import tempfile
import time

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
import child_runs  # noqa: E402
import scene_check  # noqa: E402
import tool_args  # noqa: E402

ROOT = pathlib.Path(__file__).resolve().parents[1]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default=str(ROOT / "build"))
    ap.add_argument("--duration", type=float, default=None, help="simulated time (default: the scene's, 3 t_ff)")
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--calls", type=int, default=20000, help="empty doStep calls timed")
    ap.add_argument("--threads", type=int, default=None, help="run.threads for both (default: the scene's, 2)")
    args = ap.parse_args()
    tool_args.require_counts(ap, repeat=args.repeat, calls=args.calls, threads=args.threads)
    if not pathlib.Path(args.build, "fmus").is_dir():
        ap.error(f"--build {args.build}: no fmus folder there (build first: cmake --build build)")
    if args.duration is not None and not 0 < args.duration < math.inf:
        ap.error(f"--duration = {args.duration}: must be a finite number > 0")
    build = pathlib.Path(args.build)
    grains = build / "runner" / "grains"
    tool_args.require_binary(ap, "--build", grains)
    os.environ["GRAINS_FMU_DIR"] = str(build / "fmus")
    sys.path.insert(0, str(ROOT / "tests" / "python"))
    import fmpy
    from fmu_host import Unit, fmu_path

    scene = ROOT / "models" / "aggregation.toml"
    probe = Unit(fmu_path("aggregation", 2))
    dt = probe.get("time.dt")
    probe.free()
    scene_length = fmpy.read_model_description(str(fmu_path("aggregation", 2))).defaultExperiment.stopTime
    steps = round((args.duration if args.duration else float(scene_length)) / dt)
    steps -= steps % 100
    if steps == 0:
        ap.error(f"--duration = {args.duration}: shorter than one communication step of 100 dt = {100 * dt:.6g}; give at least that")
    # The engine's own ranges (time.steps, run.threads), before anything is timed: a value it refused ended the
    # benchmark in a traceback that hid its reason.
    for option, value, override in (("--duration", args.duration, f"time.steps={steps}"),
                                    ("--threads", args.threads, f"run.threads={args.threads}")):
        if value is not None:
            try:
                scene_check.resolve(grains, scene, [override])
            except scene_check.SceneError as error:
                asked = f" ({steps:.3g} steps of dt = {dt:.6g})" if option == "--duration" else ""
                ap.error(f"{option} = {value}: grains refuses it{asked}: {scene_check.engine_refusal(error)}")
    stop = steps * dt
    print(f"aggregation scene: {steps} steps of dt = {dt:.6g} (t = {stop:.6g}), communication step 100 dt")

    threads = [] if args.threads is None else ["--set", f"run.threads={args.threads}"]
    start_values = {} if args.threads is None else {"run.threads": args.threads}

    def runner():   # (wall, CPU) seconds of the whole command
        with tempfile.TemporaryDirectory() as tmp:
            c, t = resource.getrusage(resource.RUSAGE_CHILDREN), time.perf_counter()
            child_runs.run_grains("bench_fmu.py", [grains, "run", scene, "--set", f"time.steps={steps}", *threads,
                                                   "--out", f"{tmp}/a.h5", "--quiet"])
            c2 = resource.getrusage(resource.RUSAGE_CHILDREN)
            return time.perf_counter() - t, c2.ru_utime + c2.ru_stime - c.ru_utime - c.ru_stime

    def fmu(version):   # (wall, CPU) seconds of simulate_fmu: extraction, instantiation, steps, output reads
        path = str(fmu_path("aggregation", version))
        c, t = time.process_time(), time.perf_counter()
        fmpy.simulate_fmu(path, stop_time=stop, output_interval=100 * dt, start_values=start_values)
        return time.perf_counter() - t, time.process_time() - c

    times = {"runner": [], "fmi2": [], "fmi3": []}
    for _ in range(args.repeat):
        times["runner"].append(runner())
        times["fmi2"].append(fmu(2))
        times["fmi3"].append(fmu(3))
    best = {k: (min(w for w, _ in v), min(c for _, c in v)) for k, v in times.items()}
    for k, v in times.items():
        print(f"  {k:7s} wall {', '.join(f'{w:.2f}' for w, _ in v)} s (best/runner {best[k][0] / best['runner'][0]:.3f})   "
              f"CPU {', '.join(f'{c:.2f}' for _, c in v)} s (best/runner {best[k][1] / best['runner'][1]:.3f})")

    for version in (2, 3):
        unit = Unit(fmu_path("collision", version)).initialize()
        for _ in range(1000):
            unit.fmu.doStep(0.0, 0.0)
        t = time.perf_counter()
        for _ in range(args.calls):
            unit.fmu.doStep(0.0, 0.0)
        per_call = (time.perf_counter() - t) / args.calls
        unit.free()
        print(f"  empty doStep (FMI {version}, through fmpy/ctypes): {per_call * 1e6:.2f} us per call")


if __name__ == "__main__":
    main()
