"""Phi and z at P* = 0.01 and z after the aggregation against the initial agitation V0 / V*, from the stage tables
in this folder (one subfolder per agitation) and the twenty-sixth session's equilibrium run (V0 / V* = 9.5).
    python table.py [--plot agitation.png]"""
import argparse
import csv
import math
import statistics as st
from pathlib import Path

HERE = Path(__file__).resolve().parent
BASE = HERE.parent / "equilibrium-at-0.01-4961508"
# subfolder: kinetic energy per grain over the scenes' 0.026322917 (V0 / V* = 9.5 sqrt(ratio))
RUNS = {"ke-0.5": 0.5, "ke-2": 2.0, "ke-100": 100.0}
LAWS = ("consolidation", "consolidation-rr")


def rows(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def samples(folder, law):
    out = {}
    for p in sorted(folder.glob(f"{law}-seed*.csv")):
        seed = int(p.stem.rsplit("seed", 1)[1])
        r = rows(p)
        if len(r) >= 3:
            # the P* = 0.01 stage in equilibrium; the preparation's two stages ended as they wait to
            out[seed] = (float(r[2]["solid_fraction"]), float(r[2]["coordination"]), float(r[0]["coordination"]),
                         r[2]["reached"] == "1", r[0]["reached"] == "1" and r[1]["reached"] == "1")
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--plot")
    args = ap.parse_args()
    table = {}
    for law in LAWS:
        table[(law, 1.0)] = samples(BASE, law)
        for sub, ratio in RUNS.items():
            table[(law, ratio)] = samples(HERE / sub, law)
    print("Phi(0.01) per seed: * the P* = 0.01 stage ended at its budget, † the aggregation or the relaxation at P* = 0 did")
    print()
    print("| law | V0 / V* | seeds | Phi(0.01) per seed | mean ± sd | paired with 9.5: mean difference (n) | z after aggregation | z(0.01) |")
    print("|---|---|---|---|---|---|---|---|")
    for law in LAWS:
        base = table[(law, 1.0)]
        for ratio in sorted({r for (l, r) in table if l == law}):
            s = table[(law, ratio)]
            if not s:
                continue
            phis = [v[0] for v in s.values()]
            diffs = [s[k][0] - base[k][0] for k in s if k in base]
            sd = f" ± {st.stdev(phis):.4f}" if len(phis) > 1 else ""
            paired = "" if ratio == 1.0 else f"{st.mean(diffs):+.4f} ({len(diffs)}; {sum(d < 0 for d in diffs)} lower)"
            print(f"| {law} | {9.5 * math.sqrt(ratio):.3g} | {','.join(map(str, s))} | "
                  f"{', '.join(f'{v[0]:.4f}' + ('' if v[3] else '*') + ('' if v[4] else '†') for v in s.values())} | {st.mean(phis):.4f}{sd} | "
                  f"{paired} | {st.mean(v[2] for v in s.values()):.3f} | {st.mean(v[1] for v in s.values()):.3f} |")
    if args.plot:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        fig, axes = plt.subplots(1, 2, figsize=(10, 4), sharey=True)
        paper = {"consolidation": (0.472, 0.008), "consolidation-rr": (0.524, 0.008)}
        for ax, law in zip(axes, LAWS):
            for (l, ratio), s in sorted(table.items()):
                if l != law or not s:
                    continue
                x = 9.5 * math.sqrt(ratio)
                phis = [v[0] for v in s.values()]
                settled = [v[0] for v in s.values() if v[3]]
                ax.plot([x] * len(settled), settled, "o", mfc="none", color="C0", ms=5)
                ax.plot([x] * (len(phis) - len(settled)), [v[0] for v in s.values() if not v[3]], "x", color="C0", ms=5)
                ax.plot([x], [st.mean(phis)], "_", color="C3", ms=18, mew=2)
            value, bar = paper[law]
            ax.axhspan(value - 2 * bar, value + 2 * bar, color="0.85", zorder=0, label="paper at V0/V* = 9.5, ±2 bars")
            ax.axvline(9.5, color="0.5", lw=0.8, ls=":")
            ax.set_xscale("log")
            ax.set_xlabel("initial agitation V0 / V* (the scenes': 9.5)")
            ax.set_title(f"{law}: samples (x: not in equilibrium), bars means", fontsize=10)
            ax.grid(alpha=0.3)
            ax.legend(fontsize=7)
        axes[0].set_ylabel("Φ at the end of the P* = 0.01 stage")
        fig.tight_layout()
        fig.savefig(args.plot, dpi=120)


if __name__ == "__main__":
    main()
