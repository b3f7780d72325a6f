"""Per-pair points share of one agent in two leagues (ITSF kick-off vs yellow), with Wilson CIs."""
import csv, math, sys
from collections import defaultdict

def load(path):
    pts = defaultdict(lambda: [0.0, 0, [0, 0, 0, 0, 0], [0, 0, 0, 0, 0]])  # points, n, yellow wdl gf ga, black
    for r in csv.DictReader(open(path)):
        yg, bg = int(r['yellow_goals']), int(r['black_goals'])
        for a, b, f, g, side in [(r['yellow'], r['black'], yg, bg, 2), (r['black'], r['yellow'], bg, yg, 3)]:
            e = pts[(a, b)]
            p = 1.0 if f > g else 0.5 if f == g else 0.0
            e[0] += p; e[1] += 1
            t = e[side]
            t[0 if f > g else 1 if f == g else 2] += 1; t[3] += f; t[4] += g
    return pts

def wilson(p, n, z=1.96):
    ph = p / n
    c = (ph + z * z / (2 * n)) / (1 + z * z / n)
    h = z * math.sqrt(ph * (1 - ph) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return 100 * (c - h), 100 * (c + h)

agent = sys.argv[1]
new, old = load('results/league/leaderboard/matches.csv'), load('results/league/leaderboard-yellow-kickoff/matches.csv')
print('| opponent | ITSF kick-off | as yellow | as black | every serve yellow\'s | as yellow | as black |')
print('| --- | --- | --- | --- | --- | --- | --- |')
for (a, b), e in sorted(new.items(), key=lambda kv: kv[0][1]):
    if a != agent:
        continue
    o = old.get((a, b))
    def cell(e):
        lo, hi = wilson(e[0], e[1])
        return f'{100*e[0]/e[1]:.0f} % [{lo:.0f}, {hi:.0f}]'
    def side(t):
        return f'{t[0]}-{t[1]}-{t[2]}, {t[3]}:{t[4]}'
    print(f'| {b} | {cell(e)} | {side(e[2])} | {side(e[3])} | ' + (f'{cell(o)} | {side(o[2])} | {side(o[3])} |' if o else '| | |'))
