"""The report of a generalist training run (``generalist_training.md``) and its learning curve's plot, made
from the run's record (``generalist.json``, :mod:`spark_bench.rl.generalist_recipe`)."""

from __future__ import annotations

from pathlib import Path

#: The issue's target success rate on unseen synth seeds.
TARGET = 0.9
#: What "holdable" means, as the report says it.
HOLDABLE_NOTE = (
    "Holdable: a grasp on a labelled or geometric handle, a finger-pull notch, a lid's tab or the front's edges, "
    "or the suction cup's flat patch (`suction`), that the grasp planner gives no reason against "
    "(spark_bench.rl.tasks.holdable); the rest (`face`: bare fronts; or a planner reason) neither end-effector "
    "can pull open. They count in `all`.")


def _pct(x: float | None) -> str:
    """A rate as a percentage, ``-`` for none."""
    return "-" if x is None else f"{100 * x:.1f}%"


def plot_curves(curves: dict[str, list[dict]], path: Path) -> None:
    """The learning curves (validation success against environment steps), one line per kind, as a PNG.

    :param curves: kind -> the record's ``curve`` rows
    :param path: the image to write
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4))
    for kind, rows in curves.items():
        ax.plot([r["env_steps"] for r in rows], [r["val_success"] for r in rows], marker="o", label=kind)
    ax.set_xlabel("environment steps (demonstrations + DAgger + PPO)")
    ax.set_ylabel("validation success rate")
    ax.set_ylim(-0.03, 1.03)
    ax.grid(alpha=0.3)
    ax.legend()
    ax.set_title("generalist opening policies: learning curve")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def _header(record: dict, weights: str) -> list[str]:
    """The run, the method and the seeds."""
    cores = f" on {record['cpus']} CPU cores" if record.get("cpus") else ""
    seeds = record["seeds"]
    return ["# Generalist opening policies: training run", "",
            f"Produced by `{record['produced_by']}`{cores}, {record['wall_s']:.0f} s in all. Weights: `{weights}` "
            f"version {record['version']} (feature version {record['feature_version']}); the full record is "
            "`generalist.json` beside them.",
            *([f"Scores (held-out synth, real objects) measured again with the shipped weights by "
               f"`{record['scored_by']}` ({record.get('score_wall_s', 0):.0f} s)."] if record.get("scored_by") else []),
            "", f"Method: {record['method']}.", "",
            f"Synth seeds: train {seeds['train'][0]}..{seeds['train'][-1]}, validation "
            f"{seeds['val'][0]}..{seeds['val'][-1]}, held-out test {seeds['test'][0]}..{seeds['test'][-1]} "
            "(every synth category; a task is one drawer or door). One episode per task, at most "
            f"{record['episode_steps']} steps; success = the joint passes 75 % of its range.", ""]


def _summary(record: dict) -> list[str]:
    """One row per policy: steps, wall time, held-out and real success beside the teacher's; the target."""
    lines = ["| policy | env steps (demos / DAgger / PPO) | wall | held-out synth: all | holdable grasps | "
             "teacher (all / holdable) | real objects | teacher on real (all / holdable) |",
             "|---|---|---|---|---|---|---|---|"]
    for kind, p in record["policies"].items():
        s, t, real = p["env_steps"], p["test"], p["real"]
        real_cell = "-" if real is None else (f"{_pct(real['success_rate'])} of {real['tasks']} (holdable "
                                              f"{_pct(real['holdable_success_rate'])} of {real['holdable_tasks']})")
        teach_real = "-" if real is None else (f"{_pct(real['teacher_success_rate'])} / "
                                               f"{_pct(real['holdable_teacher_success_rate'])}")
        lines.append(f"| {kind} | {s['total']:,} ({s['demos']:,} / {s['dagger']:,} / {s['ppo']:,}) | "
                     f"{p['wall_s']:.0f} s | {_pct(t['success_rate'])} of {t['tasks']} | "
                     f"{_pct(t['holdable_success_rate'])} of {t['holdable_tasks']} | "
                     f"{_pct(t['teacher_success_rate'])} / {_pct(t['holdable_teacher_success_rate'])} | "
                     f"{real_cell} | {teach_real} |")
    lines += ["", HOLDABLE_NOTE, ""]
    for kind, p in record["policies"].items():
        t = p["test"]

        def verdict(rate: float | None) -> str:
            return "met" if rate is not None and rate >= TARGET else "not met"

        lines.append(f"- Target >= {TARGET:.0%} on unseen synth seeds, {kind}: {verdict(t['success_rate'])} on all "
                     f"tasks ({_pct(t['success_rate'])}), {verdict(t['holdable_success_rate'])} on holdable grasps "
                     f"({_pct(t['holdable_success_rate'])}); the scripted teacher itself reaches "
                     f"{_pct(t['teacher_success_rate'])} / {_pct(t['holdable_teacher_success_rate'])}.")
    return lines


def _breakdowns(record: dict) -> list[str]:
    """Held-out success by grasp, by end-effector and by moving part, the policy's beside the teacher's."""
    lines = ["", "## By grasp (held-out synth; policy / teacher)", ""]
    for kind, p in record["policies"].items():
        t = p["test"]
        cells = [f"{g}: {_pct(v['success_rate'])} / {_pct(t['teacher_by_grasp'].get(g, {}).get('success_rate'))} "
                 f"({v['tasks']})" for g, v in t["by_grasp"].items()]
        lines.append(f"- {kind}: " + "; ".join(cells))
    lines += ["", "## By end-effector (held-out synth; policy / teacher)", ""]
    for kind, p in record["policies"].items():
        t = p["test"]
        if "by_end_effector" not in t:  # a record scored before rows named their end-effector
            continue
        cells = [f"{e}: {_pct(v['success_rate'])} / "
                 f"{_pct(t['teacher_by_end_effector'].get(e, {}).get('success_rate'))} ({v['tasks']})"
                 for e, v in t["by_end_effector"].items()]
        lines.append(f"- {kind}: " + "; ".join(cells))
    lines += ["", "## By moving part (held-out synth; the part's label; policy / teacher, then the policy on "
              "holdable grasps)", "",
              "The door policy's tasks are every revolute joint of every category (doors, lids, windows, "
              "screens, levers, pedals); the drawer policy's every prismatic one.", ""]
    for kind, p in record["policies"].items():
        t = p["test"]
        if "by_part" not in t:  # a record scored before rows named their part
            continue
        cells = [f"{g or '(none)'}: {_pct(v['success_rate'])} / "
                 f"{_pct(t['teacher_by_part'].get(g, {}).get('success_rate'))} ({v['tasks']}); holdable "
                 f"{_pct(t['holdable_by_part'].get(g, {}).get('success_rate'))} "
                 f"({t['holdable_by_part'].get(g, {}).get('tasks', 0)})" for g, v in t["by_part"].items()]
        lines.append(f"- {kind}: " + "; ".join(cells))
    return lines


def _curves_and_real(record: dict) -> list[str]:
    """The learning curves' tables, and every real task's outcome."""
    lines = ["", "## Learning curve (validation success)", "", "![learning curve](generalist_curve.png)", ""]
    for kind, p in record["policies"].items():
        lines += [f"### {kind}", "", "| stage | env steps | wall | validation success |", "|---|---|---|---|"]
        lines += [f"| {r['stage']} | {r['env_steps']:,} | {r['wall_s']:.0f} s | {_pct(r['val_success'])} |"
                  for r in p["curve"]]
        lines.append("")
    for kind, p in record["policies"].items():
        if p["real"] is None:
            continue
        lines += [f"## Real objects, {kind} ({p['real']['folder']})", "",
                  "| task | part | end-effector | grasp | policy | max fraction | asset sha256 |",
                  "|---|---|---|---|---|---|---|"]
        lines += [f"| {r['task']} | {r.get('part', '')} | {r.get('end_effector', 'gripper')} | {r['grasp']} | "
                  f"{'opened' if r['success_rate'] > 0 else 'no'} | {r['max_fraction']:.2f} | "
                  f"{(r.get('asset') or {}).get('sha256', '')[:12]} |" for r in p["real"]["rows"]]
        lines.append("")
    return lines


def report(record: dict, weights: str) -> str:
    """The Markdown report of a run's record.

    :param record: the run's record (``generalist.json``)
    :param weights: the weights folder as the report names it
    """
    return "\n".join(_header(record, weights) + _summary(record) + _breakdowns(record) + _curves_and_real(record))
