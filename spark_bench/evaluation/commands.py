"""``spark-bench eval``, ``spark-bench results export`` and ``spark-bench leaderboard``."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path


def add_commands(subparsers) -> None:
    """Register the benchmark-run commands on the ``spark-bench`` parser."""
    p = subparsers.add_parser("eval", help="run a method on every case of a benchmark and store the results",
                              description="Run a method on every case of a benchmark: generate (cached), "
                                          "metrics, sim-readiness checks, scripted opening; results go to "
                                          "the SQLite store. A killed run resumes where it stopped.",
                              formatter_class=EvalHelpFormatter)
    p.add_argument("--method", required=True, metavar="NAME", help=METHOD_HELP)
    p.add_argument("--method-args", action="append", metavar="KEY=VALUE,...",
                   help="the method's options, e.g. predictions=DIR,label=SINGAPO (repeatable; a value is a JSON "
                        "scalar where it parses, else text; quote a value holding a comma: label=\"a,b\"); "
                        "--method-args help lists the method's options")
    p.add_argument("--config", metavar="FILE",
                   help="a configuration file (TOML or JSON): its [method] table holds the method's options, as "
                        "--method-args (which win); its other tables configure the method itself, e.g. ours' "
                        "[prior], [optimize]... (docs/ours.md)")
    p.add_argument("--bench", default=None, help="benchmark folder or name (default: synth-v1)")
    for key, (metavar, method) in DEPRECATED_FLAGS.items():
        p.add_argument("--" + key.replace("_", "-"), dest=key, metavar=metavar,
                       help=f"deprecated: --method-args {key}={metavar} (--method {method})")
    p.add_argument("--sim", action=argparse.BooleanOptionalAction, default=True,
                   help="run sim-readiness checks and the scripted opener (default: on)")
    p.add_argument("--engine", choices=("mujoco", "physx", "all"), default="mujoco",
                   help="the simulator(s) the sim checks run in (default mujoco; physx: PhysX through SAPIEN 3 on "
                        'the CPU, pip install -e ".[physx]"; all: both). A run with PhysX is a run of its own beside '
                        "the MuJoCo-only one (docs/commands.md)")
    p.add_argument("--rl", action="store_true",
                   help="also the RL transfer score: the shipped opening policy fine-tuned on the prediction, "
                        "run on the ground truth (zero-shot and fine-tuned)")
    p.add_argument("--rl-finetune-steps", type=int, default=None, metavar="N",
                   help="fine-tuning steps per policy kind with --rl (default: 1024; 0: zero-shot only)")
    p.add_argument("--workers", type=int, default=None,
                   help="worker processes (0: in this process; default: one per usable core)")
    p.add_argument("--executor", choices=("local", "ray"), default="local",
                   help="local: a process pool; ray: Ray tasks (docs/cluster.md)")
    p.add_argument("--ray-address", help="a Ray cluster's address (default: RAY_ADDRESS, else the cluster `ray start` "
                   "runs on this machine, else a private local Ray)")
    p.add_argument("--protocol", action="append", metavar="NAME",
                   help="also score each case as a paper's own evaluation code does (repeatable, or 'all'; "
                        "docs/protocols.md): the numbers are stored in the row and shown by "
                        "`leaderboard --protocol NAME`")
    p.add_argument("--n-samples", type=int, default=100_000, help="surface samples per shape")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--align", choices=("none", "icp"), default="none")
    p.add_argument("--cases", help="comma-separated case ids (default: every case)")
    p.add_argument("--db", help="results database (default: $SPARK_BENCH_HOME/results.sqlite)")
    p.add_argument("--runs-dir", help="generation cache (default: $SPARK_BENCH_HOME/runs)")
    p.add_argument("--json", action="store_true", help="print the summary as JSON on stdout")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=run_eval_command)

    r = subparsers.add_parser("results", help="the results store")
    rsub = r.add_subparsers(dest="results_command", required=True, metavar="ACTION")
    e = rsub.add_parser("export", help="export result rows as CSV or Parquet")
    e.add_argument("--format", choices=("csv", "parquet"), default="csv")
    e.add_argument("--out", help="output file (default: results.<format> in the current folder)")
    e.add_argument("--bench", help="only this benchmark")
    e.add_argument("--method", help="only this method label")
    e.add_argument("--db", help="results database (default: $SPARK_BENCH_HOME/results.sqlite)")
    e.set_defaults(func=run_export_command)

    b = subparsers.add_parser("leaderboard", help="tables of the stored results (Markdown, LaTeX, HTML, CSV)")
    b.add_argument("--bench", help="benchmark name (default: the only one, or synth-v1)")
    b.add_argument("--format", choices=("md", "latex", "html", "csv"), default="md")
    b.add_argument("--out", help="output file (default: stdout; HTML needs a file)")
    b.add_argument("--per-category", action="store_true", help="add per-category tables")
    b.add_argument("--per-part-class", action="store_true",
                   help="articulation errors per GAPartNet part class (needs annotated ground truth)")
    b.add_argument("--methods", action="append", metavar="LABELS",
                   help="method labels to show (default: all); repeat the flag for labels that contain commas, "
                        "e.g. --methods retrieval --methods 'ours (prior=retrieval,...)', or give simple labels "
                        "comma-separated")
    b.add_argument("--max-cases", type=int, default=24, help="HTML: cases shown with renders")
    b.add_argument("--protocol", action="append", metavar="NAME",
                   help="instead of spark-bench's tables, each paper's table as that paper reports it, from the "
                        "rows `eval --protocol` stored (repeatable, or 'all')")
    b.add_argument("--db", help="results database (default: $SPARK_BENCH_HOME/results.sqlite)")
    b.set_defaults(func=run_leaderboard_command)


#: The method's options that were flags of their own, kept for one release (each prints a deprecation line):
#: option key -> (metavar, the method the flag was for).
DEPRECATED_FLAGS = {"predictions": ("DIR", "predictions"), "methods_file": ("FILE", "command"),
                    "gallery": ("DIR", "retrieval"), "entry": ("NAME", "command"),
                    "label": ("TEXT", "predictions"), "regime": ("TEXT", "predictions")}
METHOD_HELP = "the method (its names are listed by `spark-bench eval --help`)"


def method_help() -> str:
    """The help of ``--method``: every name :func:`~spark_bench.methods.registry.available_methods` lists
    (built-ins, run-time registrations, entry points), generated when the help is shown."""
    from spark_bench.methods.registry import available_methods

    return (f"one of {', '.join(available_methods())}, or an entry of a methods file "
            "(option methods_file); its options: --method-args")


class EvalHelpFormatter(argparse.HelpFormatter):
    """``eval --help``: the names of ``--method`` are looked up only when the help is printed (building the
    parser, for every command, imports no method and reads no entry point)."""

    def _get_help_string(self, action):
        if action.help is METHOD_HELP:
            return method_help()
        return super()._get_help_string(action)


def method_options(args) -> dict:
    """The method's options of ``eval``'s arguments, as given (typed and checked by
    :func:`~spark_bench.methods.registry.method_spec`): the ``[method]`` table of ``--config`` (and the
    file itself as the ``config`` option when it has other tables), overridden by ``--method-args`` and the
    deprecated flags (each printing one deprecation line).

    :raises SparkBenchError: for a key given both by ``--method-args`` and a deprecated flag
    """
    from spark_bench.errors import SparkBenchError
    from spark_bench.methods.options import parse_method_args

    given = parse_method_args(args.method_args or ())
    for key, (metavar, _) in DEPRECATED_FLAGS.items():
        value = getattr(args, key, None)
        if value is None:
            continue
        flag = "--" + key.replace("_", "-")
        print(f"spark-bench: {flag} is deprecated and goes in the next release: use --method-args {key}={metavar}",
              file=sys.stderr)
        if key in given:
            raise SparkBenchError(f"{key} is given by {flag} and by --method-args: keep --method-args")
        given[key] = value
    if not args.config:
        return given
    from spark_bench.methods.options import config_file_options, with_config_file
    from spark_bench.methods.registry import accepted_options

    table, others = config_file_options(args.config)
    options = {**table, **given}
    if others:
        options = with_config_file(args.method, args.config, options, others, accepted_options(args.method, options))
    return options


def method_spec(args):
    """The :class:`~spark_bench.methods.base.MethodSpec` of ``eval``'s arguments (:func:`method_options`; paths
    made absolute here, since workers may run elsewhere)."""
    from spark_bench.methods.registry import method_spec as spec_of

    return spec_of(args.method, method_options(args))


def _db(args) -> Path:
    from spark_bench.evaluation.runner import default_db

    return Path(args.db).expanduser() if args.db else default_db()


def _engines(args) -> tuple[str, ...]:
    """The engines of ``eval --engine``; PhysX's needs the sim stage and SAPIEN (found, not imported: the pool's
    workers are forked from this process).

    :raises SparkBenchError: ``--no-sim`` with PhysX asked for
    :raises SapienMissing: SAPIEN is not installed (one line: what to install)
    """
    import importlib.util

    from spark_bench.errors import SparkBenchError
    from spark_bench.sim.physx import INSTALL_HINT, SapienMissing
    from spark_bench.sim.physx.engines import engine_names

    engines = engine_names(args.engine)
    if "physx" in engines and not args.sim:
        raise SparkBenchError(f"--engine {args.engine} runs the sim checks: leave out --no-sim")
    found = sys.modules["sapien"] is not None if "sapien" in sys.modules else importlib.util.find_spec("sapien")
    if "physx" in engines and not found:
        raise SapienMissing(INSTALL_HINT)
    return engines


def _method_args_help(args) -> int | None:
    """``--method-args help``: print the method's options instead of running it (0); None when not asked."""
    texts = args.method_args or ()
    if not any(text.strip() == "help" for text in texts):
        return None
    from spark_bench.methods.options import describe_options
    from spark_bench.methods.registry import accepted_options

    rest = argparse.Namespace(**{**vars(args), "method_args": [t for t in texts if t.strip() != "help"]})
    sys.stdout.write(describe_options(args.method, accepted_options(args.method, method_options(rest))))
    return 0


def run_eval_command(args) -> int:
    asked = _method_args_help(args)
    if asked is not None:
        return asked
    from spark_bench.evaluation.runner import EvalOptions, run_eval, usable_cores
    from spark_bench.metrics.protocols import protocol_names

    protocols = tuple(protocol_names(args.protocol)) if args.protocol else ()  # an unknown name fails first
    engines = _engines(args)
    spec = method_spec(args)
    options = EvalOptions(sim=args.sim, rl=args.rl, n_samples=args.n_samples, seed=args.seed, align=args.align,
                          protocols=protocols, engines=engines,
                          **({} if args.rl_finetune_steps is None else {"rl_finetune_steps": args.rl_finetune_steps}))
    cases = [c for c in args.cases.split(",") if c] if args.cases else None
    workers = usable_cores() if args.workers is None else args.workers
    summary = run_eval(spec, args.bench, options, db=_db(args), workers=workers, executor=args.executor,
                       runs_root=Path(args.runs_dir).expanduser() if args.runs_dir else None,
                       progress=not args.no_progress, ray_address=args.ray_address, cases=cases)
    if args.json:
        print(json.dumps(summary.to_json()))
        return 0
    from spark_bench.evaluation.board import coverage_text, fmt_scale, fmt_value
    from spark_bench.metrics.names import COVERAGES

    def shown(key: str, value) -> str:
        if key in COVERAGES:
            return coverage_text(key, value)
        if key == "alignment_scale":
            return f"{fmt_scale(value)} over {value['cases']} aligned cases (median, range)"
        return fmt_value(value)

    print(f"{summary.run.label} on {summary.run.bench}: {summary.n_cases} cases, {summary.n_failed} failed, "
          f"{summary.n_skipped} already done, {summary.seconds:.1f} s")
    width = max((len(key) for key in summary.metrics), default=0)
    for key, value in summary.metrics.items():
        print(f"  {key:>{width}}  {shown(key, value)}")
    for case_id, reason in list(summary.failures.items())[:20]:
        print(f"  failed {case_id}: {reason}", file=sys.stderr)
    return 0


def run_export_command(args) -> int:
    from spark_bench.evaluation.store import ResultsStore, export_rows

    out = Path(args.out or f"results.{args.format}")
    with ResultsStore(_db(args)) as store:
        rows = store.rows(bench=args.bench, label=args.method)
    export_rows(rows, out, args.format)
    print(f"wrote {len(rows)} rows to {out}", file=sys.stderr)
    return 0


def run_leaderboard_command(args) -> int:
    from spark_bench.errors import SparkBenchError
    from spark_bench.evaluation.leaderboard import build_leaderboard, render
    from spark_bench.evaluation.store import ResultsStore

    if args.protocol:
        return _write(_protocol_text(args), args.out)
    with ResultsStore(_db(args)) as store:
        board = build_leaderboard(store, bench=args.bench,
                                  labels=args.methods)
    if args.format == "html" and not args.out:
        raise SparkBenchError("--format html needs --out FILE (images are written beside it)")
    text = render(board, args.format, per_category=args.per_category, per_part_class=args.per_part_class,
                  out=Path(args.out) if args.out else None, max_cases=args.max_cases)
    return _write(text, args.out)


def _protocol_text(args) -> str:
    """``leaderboard --protocol``: the papers' tables of the benchmark ``leaderboard`` would show."""
    from spark_bench.evaluation.leaderboard import default_bench
    from spark_bench.evaluation.protocol_board import protocol_boards
    from spark_bench.evaluation.store import ResultsStore

    with ResultsStore(_db(args)) as store:
        bench = args.bench or default_bench(store)
        return protocol_boards(store, bench, args.protocol, args.format, labels=args.methods)


def _write(text: str, out: str | None) -> int:
    """Write ``text`` to ``out`` (folders made), or to stdout."""
    if out:
        Path(out).parent.mkdir(parents=True, exist_ok=True)
        Path(out).write_text(text)
        print(f"wrote {out}", file=sys.stderr)
    else:
        sys.stdout.write(text)
    return 0
