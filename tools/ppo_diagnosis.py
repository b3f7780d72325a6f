#!/usr/bin/env python3
"""How each PPO run's updates behaved, from its scalars.csv (docs/journal/study.md, "Normalised
observations and rewards"): the median approximate KL and clipped share per update, the
policy's entropy at the first and last update, and the median gradient norm before
clipping. Standard library only.

    python3 tools/ppo_diagnosis.py results/figure2-v5/ppo-seed0 results/ppo-normalize/ppo-seed0
"""
import csv
import statistics
import sys


def main(runs):
    for run in runs:
        tags = {}
        with open(f"{run}/scalars.csv", newline="") as f:
            for row in csv.DictReader(f):
                tags.setdefault(row["tag"], []).append(float(row["value"]))
        try:
            kl, clipped = tags["train/approx_kl"], tags["train/clip_fraction"]
            entropy, norm = tags["train/entropy"], tags["train/grad_norm"]
        except KeyError as missing:
            sys.exit(f"{run}/scalars.csv: no {missing} rows (not a PPO run?)")
        print(
            f"{run}: approx_kl median {statistics.median(kl):.3g}, "
            f"clip_fraction median {statistics.median(clipped):.3f}, "
            f"entropy first {entropy[0]:.2f} last {entropy[-1]:.2f}, "
            f"grad_norm median {statistics.median(norm):.3g}"
        )


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    main(sys.argv[1:])
