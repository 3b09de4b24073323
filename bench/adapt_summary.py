#!/usr/bin/env python3
"""Summary of bench/adapt_work_precision.sh: per case and target certified relative error
(1e-2, 1e-3), the unknowns and seconds of the first adaptive step and of the first uniform
level that reach it (a target not reached is extrapolated from the last two rows, marked
'~'), and the rate p of sqrt(est) ~ ndof^-p fitted over the adaptive steps with ndof >= 1000.
The adaptive arm of a target is the run with that tol when there is one
(out/wp/<case>_adapt_tol1e-2.csv: where a user asking for 1e-2 stops), else the 1e-3 run.
Writes out/wp/summary.md (a Markdown table) and prints it."""
import csv, glob, math, os

def rows(path):
    return list(csv.DictReader(open(path)))

def first_reach(pts, target):
    """pts: [(ndof, rel, seconds)] in order; the first with rel <= target, or an
    extrapolation (ndof and seconds by the log-log slope of the last two points)."""
    for n, r, s in pts:
        if r == r and r <= target:
            return n, s, False
    (n1, r1, s1), (n2, r2, s2) = pts[-2], pts[-1]
    p = math.log(r1 / r2) / math.log(n2 / n1)        # rel ~ ndof^-p
    n = n2 * (r2 / target) ** (1.0 / p)
    s = s2 * (n / n2) ** (math.log(s2 / s1) / math.log(n2 / n1))
    return n, s, True

lines = ['| case | target | adaptive ndof | adaptive s | uniform ndof | uniform s | ndof ratio | time ratio | adaptive rate p |',
         '| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |']
for upath in sorted(glob.glob('out/wp/*_uniform.csv')):
    name = os.path.basename(upath)[:-len('_uniform.csv')]
    apath = f'out/wp/{name}_adapt.csv'
    if not os.path.exists(apath):
        continue
    u = [(int(r['ndof']), float(r['rel_cert']), float(r['seconds'])) for r in rows(upath)]
    a = [(int(float(r['ndof'])), float(r['rel_cert']) if r['rel_cert'] not in ('', 'nan') else float('nan'),
          float(r['elapsed_s'])) for r in rows(apath)]
    ests = [(int(float(r['ndof'])), float(r['est'])) for r in rows(apath) if float(r['ndof']) >= 1000]
    if len(ests) > 2:
        xs = [math.log(n) for n, _ in ests]
        ys = [0.5 * math.log(e) for _, e in ests]
        mx, my = sum(xs) / len(xs), sum(ys) / len(ys)
        rate = -sum((x - mx) * (y - my) for x, y in zip(xs, ys)) / sum((x - mx) ** 2 for x in xs)
    else:
        rate = float('nan')
    u = [p for p in u if p[1] == p[1]]
    a = [p for p in a if p[1] == p[1]]
    tpath = f'out/wp/{name}_adapt_tol1e-2.csv'
    a_tol = {1e-2: [(int(float(r['ndof'])), float(r['rel_cert']) if r['rel_cert'] not in ('', 'nan') else float('nan'),
                     float(r['elapsed_s'])) for r in rows(tpath)] if os.path.exists(tpath) else []}
    for target in (1e-2, 1e-3):
        at = [p for p in a_tol.get(target, []) if p[1] == p[1]]
        na, sa, xa = first_reach(at if at else a, target)
        nu, su, xu = first_reach(u, target)
        f = lambda n, x: ('~' if x else '') + f'{n:.3g}'
        lines.append(f'| {name} | {target:g} | {f(na, xa)} | {f(sa, xa)} | {f(nu, xu)} | {f(su, xu)} | '
                     f'{("~" if xa or xu else "")}{nu / na:.3g} | {("~" if xa or xu else "")}{su / sa:.3g} | {rate:.3f} |')
text = '\n'.join(lines) + '\n'
open('out/wp/summary.md', 'w').write(text)
print(text)
