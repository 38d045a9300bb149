#!/usr/bin/python3
"""Compare cloth_sim with Bullet's soft-body cloth: for each grid size and each side, the cheapest setting that
keeps the hanging cloth's structural strain within a bound, then a dynamic case at that setting.

    bench.py --bench PATH_TO_cloth_bench [--sizes 20,64,128,256] [--frames N] [--quick]
             [--out .build/bench_results.json]

Prints markdown tables on stdout, progress on stderr, and saves every raw JSON line cloth_bench printed (with the
arguments that produced it) to --out. Python 3 standard library only (make bench runs it with /usr/bin/python3).

A setting passes when every simulated frame stays finite, none is rolled back, and the largest structural strain
(|d| - L) / L stays within the bound. Our candidates are implicit Euler at 1 or 2 substeps with a structural
stiffness from a ladder; Bullet's are (substeps, position iterations) rungs ordered by cost.
"""

import argparse
import datetime
import json
import math
import os
import platform
import subprocess
import sys
import time

STRAIN_BOUND = 0.05
# "Real fabric strains about 1% under its own weight": the second table asks for this.
FABRIC_STRAIN_BOUND = 0.01

OUR_INTEGRATOR = "implicit_euler"
OUR_SUBSTEPS = 1
# Conjugate-gradient iterations per step at most (solver_max_iterations). With the multigrid preconditioner (the
# default) a solve converges to the default tolerance in about 3 to 6 iterations at every size here, so ours run
# converged: the default cap (100) stays, as a safety net that no run reaches. (With block-Jacobi this search
# used caps 10, 20, 50, 100, 200, cheap first; a capped solve is a different, over-stretched cloth in motion.)
OUR_SOLVER_CAPS = (100,)
# N/m per structural spring, soft to stiff: a stiffer cloth stretches less at about the same cost per
# iteration, so at a fixed cap the first stiffness that passes is the one to keep.
OUR_STIFFNESSES = (1000, 5000, 20000, 100000, 500000)
# Bullet (substeps, position iterations), ordered by cost. Its cost grows about as substeps * (iterations + 3)
# (measured at 64 and 128 per side), which BULLET_COST_OFFSET encodes for the skip estimate below.
BULLET_LADDER = ((1, 1), (1, 4), (4, 4), (10, 1), (10, 4), (40, 1), (40, 4), (80, 8))
BULLET_COST_OFFSET = 3

DEFAULT_SIZES = (20, 64, 128, 256)
QUICK_SIZES = (20, 64)
DEFAULT_FRAMES = 50
QUICK_FRAMES = 20
# From this many particles per side, runs take seconds per frame: fewer frames keep the whole bench sane.
LARGE_SIZE = 256
DEFAULT_LARGE_FRAMES = 20
DEFAULT_WARMUP = 5
QUICK_WARMUP = 2
DEFAULT_TIMEOUT_S = 300.0

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def log(message):
    print(message, file=sys.stderr, flush=True)


def parse_args(argv):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--bench", required=True, help="the cloth_bench executable")
    parser.add_argument("--sizes", help="particles per side, comma-separated (default %s; --quick: %s)"
                        % (",".join(map(str, DEFAULT_SIZES)), ",".join(map(str, QUICK_SIZES))))
    parser.add_argument("--frames", type=int, help="timed frames per run (default %d; --quick: %d)"
                        % (DEFAULT_FRAMES, QUICK_FRAMES))
    parser.add_argument("--large-frames", type=int, default=DEFAULT_LARGE_FRAMES,
                        help="most timed frames at %d per side and above (default %d)"
                        % (LARGE_SIZE, DEFAULT_LARGE_FRAMES))
    parser.add_argument("--quick", action="store_true", help="sizes %s, %d frames, %d warm-up frames"
                        % (",".join(map(str, QUICK_SIZES)), QUICK_FRAMES, QUICK_WARMUP))
    parser.add_argument("--timeout", type=float, default=DEFAULT_TIMEOUT_S,
                        help="seconds one cloth_bench run may take; Bullet rungs estimated to take longer are "
                             "skipped (default %(default)s)")
    parser.add_argument("--out", default=os.path.join(REPO, ".build", "bench_results.json"),
                        help="where the raw results go, one JSON document (default .build/bench_results.json)")
    args = parser.parse_args(argv)

    if args.sizes:
        try:
            args.sizes = [int(s) for s in args.sizes.split(",") if s.strip()]
        except ValueError:
            parser.error("--sizes: expected integers separated by commas, got %r" % args.sizes)
    else:
        args.sizes = list(QUICK_SIZES if args.quick else DEFAULT_SIZES)
    if not args.sizes or any(s < 2 for s in args.sizes):
        parser.error("--sizes: every size must be >= 2")
    if args.frames is None:
        args.frames = QUICK_FRAMES if args.quick else DEFAULT_FRAMES
    if args.frames < 1 or args.large_frames < 1:
        parser.error("--frames and --large-frames must be >= 1")
    # 0 or less would time every run out at once (a TimeoutExpired traceback); inf or nan is no limit at all.
    if not (math.isfinite(args.timeout) and args.timeout > 0):
        parser.error("--timeout must be a number of seconds above 0, not %s" % args.timeout)
    args.warmup = QUICK_WARMUP if args.quick else DEFAULT_WARMUP
    if not (os.path.isfile(args.bench) and os.access(args.bench, os.X_OK)):
        parser.error("--bench %s: not an executable file" % args.bench)
    return args


class Bench:
    """Runs cloth_bench and keeps every result, in order, for --out."""

    def __init__(self, executable, timeout_s):
        self.executable = executable
        self.timeout_s = timeout_s
        self.records = []
        self.run_count = 0
        self.failures = 0  # runs that crashed or timed out (a setting that fails the bound is not one)

    def run(self, purpose, args):
        """One cloth_bench run; its JSON dict, or None if it crashed or timed out (both logged and recorded)."""
        self.run_count += 1
        command = [self.executable] + [str(a) for a in args]
        label = "[%d] %s: %s" % (self.run_count, purpose, " ".join(str(a) for a in args))
        start = time.monotonic()
        try:
            done = subprocess.run(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True,
                                  timeout=self.timeout_s)
        except subprocess.TimeoutExpired:
            self.failures += 1
            log("%s ... timed out after %.0f s" % (label, self.timeout_s))
            self.records.append({"purpose": purpose, "args": command[1:], "error": "timed out",
                                 "wall_s": round(self.timeout_s, 1)})
            return None
        wall_s = time.monotonic() - start
        result = parse_result(done.stdout) if done.returncode == 0 else None
        if result is None:
            self.failures += 1
            log("%s ... FAILED (exit %d) after %.1f s:\n%s" % (label, done.returncode, wall_s, done.stderr.rstrip()))
            self.records.append({"purpose": purpose, "args": command[1:], "error": done.stderr.strip(),
                                 "exit": done.returncode, "wall_s": round(wall_s, 2)})
            return None
        log("%s ... %.1f s: %s" % (label, wall_s, describe(result)))
        self.records.append({"purpose": purpose, "args": command[1:], "wall_s": round(wall_s, 2), "result": result})
        return result

    def has_bullet(self):
        """Whether this cloth_bench can run Bullet: one built without it exits with 2 (usage) for --bullet."""
        probe = [self.executable, "--bullet", "--rows", "4", "--cols", "4", "--substeps", "1", "--frames", "1"]
        done = subprocess.run(probe, stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True,
                              timeout=self.timeout_s)
        if done.returncode != 0:
            log("bench: no Bullet comparison: %s exited with %d: %s"
                % (" ".join(probe), done.returncode, done.stderr.strip()))
        return done.returncode == 0


def parse_result(stdout):
    lines = [line for line in stdout.splitlines() if line.strip()]
    if len(lines) != 1:
        return None
    try:
        return json.loads(lines[0])
    except ValueError:
        return None


def describe(result):
    text = "strain %s, %s ms/frame" % (fmt_strain(result["max_strain"]), fmt_number(result["ms_per_frame"]))
    if result.get("stopped"):
        text += " (stopped: %s)" % result["stopped"]
    return text


def passes(result, bound):
    """The setting kept the cloth finite, rolled nothing back and stretched it at most `bound`."""
    return (completed(result) and result["finite"] and result["rolled_back"] == 0
            and result["max_strain"] <= bound)


def completed(result):
    """The run simulated all its frames, so its timings compare with another's (its strain may be anything)."""
    return result is not None and not result.get("stopped") and result["ms_per_frame"] is not None


def frames_for(size, args):
    return min(args.frames, args.large_frames) if size >= LARGE_SIZE else args.frames


# ---- the two sides ---------------------------------------------------------------------------------------------


def our_args(size, setting, frames, warmup, dynamic, stop_strain):
    cap, stiffness = setting
    args = ["--scene", "hanging", "--rows", size, "--cols", size, "--integrator", OUR_INTEGRATOR,
            "--substeps", OUR_SUBSTEPS, "--set", "structural_stiffness=%g" % stiffness,
            "--set", "solver_max_iterations=%d" % cap, "--frames", frames, "--warmup", warmup,
            "--stop-above-strain", stop_strain]
    return args + (["--dynamic"] if dynamic else [])


def our_setting_name(setting):
    cap, stiffness = setting
    return "%s S=%d CG<=%d K=%g N/m" % (OUR_INTEGRATOR, OUR_SUBSTEPS, cap, stiffness)


def bullet_args(size, setting, frames, dynamic):
    substeps, iterations = setting
    args = ["--bullet", "--scene", "hanging", "--rows", size, "--cols", size, "--substeps", substeps,
            "--iterations", iterations, "--frames", frames]
    return args + (["--dynamic"] if dynamic else [])


def bullet_setting_name(setting):
    return "bullet_pbd S=%d I=%d" % setting


def bullet_cost(setting):
    substeps, iterations = setting
    return substeps * (iterations + BULLET_COST_OFFSET)


class Choice:
    """The outcome of one search: the chosen setting and its run, or the least-strain run if none passed."""

    def __init__(self, setting, result, met, name):
        self.setting, self.result, self.met, self.name = setting, result, met, name


def search_ours(bench, size, args, cache, dynamic=False):
    """Per CG iteration cap, cheap first, stiffnesses soft to stiff until one keeps the strain within 1%: a
    stiffer cloth or a larger cap would only cost more. Every run stops as soon as its strain passes 5%: it
    has failed both bounds by then. dynamic: the cloth released flat (where a truncated solve shows)."""
    frames = frames_for(size, args)
    case = "dynamic" if dynamic else "hanging"
    for cap in OUR_SOLVER_CAPS:
        for stiffness in OUR_STIFFNESSES:
            setting = (cap, stiffness)
            cache[setting] = bench.run("%dx%d ours %s" % (size, size, case),
                                       our_args(size, setting, frames, args.warmup, dynamic, STRAIN_BOUND))
            if passes(cache[setting], FABRIC_STRAIN_BOUND):
                return [pick(cache, bound, our_setting_name) for bound in (STRAIN_BOUND, FABRIC_STRAIN_BOUND)]
    return [pick(cache, bound, our_setting_name) for bound in (STRAIN_BOUND, FABRIC_STRAIN_BOUND)]


def search_bullet(bench, size, args, cache):
    """Up the cost ladder until a rung keeps the strain within 1%. A rung estimated (from the last rung's time) to
    take longer than --timeout is skipped, and so is everything above it."""
    frames = frames_for(size, args)
    last = None  # (setting, ms per frame) of the last rung run
    for setting in BULLET_LADDER:
        if last and last[1] is not None:
            estimate_s = last[1] / 1000.0 * bullet_cost(setting) / bullet_cost(last[0]) * frames
            if estimate_s > bench.timeout_s:
                log("%dx%d bullet: skipping %s and above (estimated %.0f s > --timeout %.0f s)"
                    % (size, size, bullet_setting_name(setting), estimate_s, bench.timeout_s))
                break
        cache[setting] = bench.run("%dx%d bullet hanging" % (size, size), bullet_args(size, setting, frames, False))
        if passes(cache[setting], FABRIC_STRAIN_BOUND):
            break
        last = (setting, cache[setting]["ms_per_frame"] if cache[setting] else None)
    return [pick(cache, bound, bullet_setting_name) for bound in (STRAIN_BOUND, FABRIC_STRAIN_BOUND)]


def pick(cache, bound, name_of):
    """The cheapest setting run that passed, or, if none did, the run with the least strain (marked as such)."""
    passing = [s for s in cache if passes(cache[s], bound)]
    if passing:
        best = min(passing, key=lambda s: cache[s]["ms_per_frame"])
        return Choice(best, cache[best], True, name_of(best))
    ran = [s for s in cache if cache[s] is not None]
    if not ran:
        return Choice(None, None, False, "none ran")
    best = min(ran, key=lambda s: cache[s]["max_strain"])
    return Choice(best, cache[best], False, "none <= %g%% (least strain: %s)" % (bound * 100, name_of(best)))


# ---- report ----------------------------------------------------------------------------------------------------


def fmt_number(value, digits=3):
    if value is None:
        return "-"
    if value >= 100:
        return "%.0f" % value
    return ("%." + str(digits) + "g") % value


def fmt_strain(value):
    if value is None:
        return "-"
    percent = value * 100
    return "%.2f%%" % percent if percent < 1000 else "%.0f%%" % percent


def strain_cell(result):
    text = fmt_strain(result["max_strain"])
    if result.get("stopped"):
        text = ">= " + text + " (stopped)"
    elif not result["finite"]:
        text += " (not finite)"
    elif result["rolled_back"]:
        text += " (%d rolled back)" % result["rolled_back"]
    return text


def table(title, rows):
    """rows: (size, entries), entries: (side, result or None, setting text, met) with ours first. The ratio is
    shown only where both sides met the bound: otherwise it would compare a cloth that held with one that did not."""
    lines = ["### " + title, "",
             "| size | side | setting | ms/frame | max strain | realtime factor | rss MB | Bullet ms / ours ms |",
             "|---|---|---|---:|---:|---:|---:|---:|"]
    for size, entries in rows:
        ours = entries[0] if entries and entries[0][0] == "cloth_sim" else None
        ours_ms = ours[1]["ms_per_frame"] if ours and ours[1] and ours[3] else None
        for side, result, setting, met in entries:
            if result is None:
                lines.append("| %dx%d | %s | %s | - | - | - | - | - |" % (size, size, side, setting))
                continue
            ratio = "-"
            if side == "bullet" and met and ours_ms and result["ms_per_frame"]:
                ratio = "%.2f" % (result["ms_per_frame"] / ours_ms)
            lines.append("| %dx%d | %s | %s | %s | %s | %s | %s | %s |" % (
                size, size, side, setting, fmt_number(result["ms_per_frame"]), strain_cell(result),
                fmt_number(result["realtime_factor"]), fmt_number(result["rss_mb"]), ratio))
    return "\n".join(lines) + "\n"


def machine_description():
    model = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as cpuinfo:
            for line in cpuinfo:
                if line.startswith("model name"):
                    model = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    return "%s, %d cores" % (model, os.cpu_count() or 1)


def save(path, args, records, started):
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    header = {"generated": started, "machine": machine_description(), "sizes": args.sizes, "frames": args.frames,
              "large_frames": args.large_frames, "warmup": args.warmup, "strain_bound": STRAIN_BOUND,
              "fabric_strain_bound": FABRIC_STRAIN_BOUND}
    # One run per line, so that a diff of two benches reads run by run.
    with open(path, "w") as out:
        out.write("{\"bench\": %s,\n \"runs\": [\n" % json.dumps(header))
        out.write(",\n".join("  " + json.dumps(record) for record in records))
        out.write("\n ]}\n")


def main(argv):
    args = parse_args(argv)
    started = datetime.datetime.now().isoformat(timespec="seconds")
    bench = Bench(args.bench, args.timeout)
    bullet = bench.has_bullet()
    start = time.monotonic()

    strain_rows, fabric_rows, dynamic_rows = [], [], []
    for size in args.sizes:
        ours_cache, bullet_cache = {}, {}
        ours_5, ours_1 = search_ours(bench, size, args, ours_cache)
        entries_5 = [("cloth_sim", ours_5.result, ours_5.name, ours_5.met)]
        entries_1 = [("cloth_sim", ours_1.result, ours_1.name, ours_1.met)]
        # The dynamic case is searched on its own: a cloth released flat needs its solves to converge, where
        # the resting hanging cloth gets away with a truncated one.
        dynamic_5, _ = search_ours(bench, size, args, {}, dynamic=True)
        dynamic = [("cloth_sim", dynamic_5.result, dynamic_5.name, dynamic_5.met)]
        if bullet:
            bullet_5, bullet_1 = search_bullet(bench, size, args, bullet_cache)
            entries_5.append(("bullet", bullet_5.result, bullet_5.name, bullet_5.met))
            entries_1.append(("bullet", bullet_1.result, bullet_1.name, bullet_1.met))
            if bullet_5.setting:
                result = bench.run("%dx%d bullet dynamic" % (size, size),
                                   bullet_args(size, bullet_5.setting, frames_for(size, args), True))
                dynamic.append(("bullet", result, bullet_5.name, bullet_5.met and completed(result)))
        strain_rows.append((size, entries_5))
        fabric_rows.append((size, entries_1))
        dynamic_rows.append((size, dynamic))
        save(args.out, args, bench.records, started)  # after every size, so an interrupted bench keeps its runs

    log("bench: %d runs in %.0f s; raw results in %s" % (bench.run_count, time.monotonic() - start, args.out))
    print("## cloth_sim vs Bullet soft body: hanging cloth, %s\n" % machine_description())
    print("Each row: the cheapest setting tried whose cloth stayed finite, rolled nothing back and kept its "
          "structural strain within the bound over every frame (%d frames, %d at %d per side and above; ours "
          "after %d untimed warm-up frames, which count for strain). Ours: %s at %d step per frame, CG with the "
          "default preconditioner to the default tolerance (cap %s iterations, a safety net), structural stiffness %s N/m. Bullet: (substeps S, position iterations I) in %s.\n" % (
              args.frames, min(args.frames, args.large_frames), LARGE_SIZE, args.warmup, OUR_INTEGRATOR,
              OUR_SUBSTEPS, ", ".join("%d" % c for c in OUR_SOLVER_CAPS),
              ", ".join("%g" % k for k in OUR_STIFFNESSES), ", ".join("(%d,%d)" % s for s in BULLET_LADDER)))
    print(table("Strain <= %g%%" % (STRAIN_BOUND * 100), strain_rows))
    print(table("Strain <= %g%% (real fabric strains about 1%% under its own weight)" % (FABRIC_STRAIN_BOUND * 100),
                fabric_rows))
    print(table("Dynamic: released flat, swinging down (ours searched again; Bullet at its 5% hanging setting)",
                dynamic_rows))
    if not bullet:
        print("Bullet: not compared (this cloth_bench was built without it).\n")
    if bench.failures:
        log("bench: %d runs crashed or timed out (see above and %s)" % (bench.failures, args.out))
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
