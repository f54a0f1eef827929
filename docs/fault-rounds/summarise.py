#!/usr/bin/env python3
# Per fault of a round: vectors whose verdict changed against the baseline, must pass->fail first.
#   summarise.py ROUND [TAG]   (ROUND: s17, s18, ...; TAG: the suffix run.sh wrote, e.g. alt ->
#                              base-alt.json, hand-NN-alt.json)
import json, sys, os
if len(sys.argv) < 2:
    sys.exit('usage: summarise.py ROUND [TAG]')
R = os.path.join(os.path.dirname(os.path.abspath(__file__)), sys.argv[1], 'results')
tag = ('-' + sys.argv[2]) if len(sys.argv) > 2 else ''
def load(name):
    d = json.load(open(os.path.join(R, name)))
    return {v['id']: v for v in d['vectors']}
base = load(f'base{tag}.json')
for n in [f'{i:02d}' for i in range(1, 17)]:
    f = os.path.join(R, f'hand-{n}{tag}.json')
    if not os.path.exists(f): continue
    run = load(f'hand-{n}{tag}.json')
    changed = [(i, base[i].get('verdict'), v.get('verdict'), v.get('level')) for i, v in run.items()
               if i in base and base[i].get('verdict') != v.get('verdict')]
    must_fail = [c for c in changed if c[3] == 'must' and c[1] == 'pass' and c[2] == 'fail']
    errs = [c for c in changed if c[2] == 'error']
    other = [c for c in changed if c not in must_fail and c not in errs]
    print(f'hand-{n}{tag}: must pass->fail {len(must_fail)}, ->error {len(errs)}, other {len(other)}')
    for c in (must_fail[:12] + errs[:5] + other[:8]):
        print('   ', c)
