"""Whether a campaign tool may take a run's output as made with the settings asked for now: the scene the run ran
(its HDF5 file's parameters/scene.toml) against the scene and overrides as `grains check` resolves them
(scene_check.resolve). Used by runner/consolidation_campaign.py, runner/aggregation_sweep.py and
runner/same_unfinished_run.py."""
import run_files


# How many threads ran a run is not what it ran: a campaign resumed with other --jobs or --threads reuses it.
IGNORED = {"run.threads"}


class Stale(Exception):
    """A finished run that ran other settings than those asked for now."""


def flat(scene):
    return {f"{section}.{key}": value for section, table in scene.items() for key, value in table.items()}


def difference(now, h5):
    """None when the run in h5 ran the scene `now` (run.threads aside), else what differs, e.g.
    "particles.count = 80 there, 200 now"."""
    then = run_files.stored(h5)
    if then is None:
        kind = run_files.not_a_regular_file(h5)
        return (f"{h5} is {kind}, not an HDF5 file grains wrote" if kind
                else f"{h5} is missing or holds no scene (parameters/scene.toml)")
    then, now = flat(then), flat(now)
    shown = lambda scene, key: repr(scene[key]) if key in scene else "unset"
    differs = [f"{key} = {shown(then, key)} there, {shown(now, key)} now" for key in sorted(then.keys() | now.keys())
               if key not in IGNORED and repr(then.get(key)) != repr(now.get(key))]   # repr: NaN equals NaN
    if not differs:
        return None
    return "; ".join(differs[:4]) + (f" and {len(differs) - 4} more" if len(differs) > 4 else "")
