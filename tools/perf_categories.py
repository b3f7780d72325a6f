"""Where a profiled run's time goes, by kind of work: `perf report`'s flat profile summed
into a few categories by symbol name (docs/table.md, "Speed"). A measuring instrument:

    RAYON_NUM_THREADS=1 perf record -F 2000 -g -o /tmp/perf.sac64 \\
        target/release/deps/update_speed-<hash> --sizes 64x2 --reps 100 --algos sac
    python3 tools/perf_categories.py /tmp/perf.sac64

Prints a markdown table, one row per category, its share of the samples in percent.
"""

import re
import subprocess
import sys

# First matching pattern wins; the order matters (e.g. `unary_op` before `alloc`).
CATEGORIES = [
    ("matrix products (gemm kernels and packing)", r"gemm|matmul|pulp"),
    (
        "element-wise math (exp, tanh, log; burn-flex unary, binary, zip, reductions)",
        r"expm1|tanh|expf|logf|log1p|unary|binary|zip|macerator|powf|sqrt|broadcast|mask"
        r"|clamp|reduce|sum_|mean",
    ),
    (
        "allocation, zero-filling, copies",
        r"mi_|malloc|free|memmove|memcpy|memset|Bytes|alloc|FlexTensor::empty|clone|drop",
    ),
    ("autodiff graph bookkeeping", r"autodiff|Graph|hashbrown|hash_one|HashMap|smallvec|checkpoint"),
    ("random numbers", r"rand|chacha|Normal|ziggurat"),
]
OTHER = "other (dispatch, rayon, shapes, our code)"


def main() -> None:
    if len(sys.argv) != 2:
        raise SystemExit("usage: perf_categories.py PERF_DATA")
    report = subprocess.run(
        ["perf", "report", "-i", sys.argv[1], "--no-children", "--sort", "symbol", "--stdio", "-g", "none"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    shares = {name: 0.0 for name, _ in CATEGORIES} | {OTHER: 0.0}
    for line in report.splitlines():
        m = re.match(r"\s+([0-9.]+)%\s+\[.\]\s+(.*)", line)
        if not m:
            continue
        share, symbol = float(m.group(1)), m.group(2)
        name = next((n for n, pattern in CATEGORIES if re.search(pattern, symbol)), OTHER)
        shares[name] += share
    print("| where the time goes | share |")
    print("| --- | --- |")
    for name, share in sorted(shares.items(), key=lambda kv: -kv[1]):
        print(f"| {name} | {share:.0f} % |")


if __name__ == "__main__":
    main()
