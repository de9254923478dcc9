#!/usr/bin/env bash
# Keep the README and docs/ honest (scripts/test.sh runs this):
# - README.md has at most 250 lines;
# - every relative link in README.md and docs/*.md points at a file or
#   directory that exists (anchors are not checked);
# - every figures block is well formed (one begin, one end, in that order),
#   so scripts/docs-figures.sh can rewrite it.
set -euo pipefail
cd "$(dirname "$0")/.."

python3 - README.md docs/*.md <<'PY'
import os, re, sys

MAX_README_LINES = 250
failed = False

def fail(msg):
    global failed
    failed = True
    print(f'check-docs: {msg}')

n = sum(1 for _ in open('README.md', encoding='utf-8'))
if n > MAX_README_LINES:
    fail(f'README.md has {n} lines (at most {MAX_README_LINES}); move detail into docs/')

link = re.compile(r'\[[^\]]*\]\(([^)\s]+)(?:\s+"[^"]*")?\)')
fence = re.compile(r'^\s*(```|~~~)')
for path in sys.argv[1:]:
    text = open(path, encoding='utf-8').read()
    in_code = False
    for lineno, line in enumerate(text.split('\n'), 1):
        if fence.match(line):
            in_code = not in_code
            continue
        if in_code:
            continue
        # inline code spans are not links
        line = re.sub(r'`[^`]*`', '', line)
        for target in link.findall(line):
            if re.match(r'^[a-z][a-z0-9+.-]*:', target) or target.startswith('#'):
                continue  # URL, mail address or an anchor in the same file
            file = target.split('#', 1)[0]
            resolved = os.path.normpath(os.path.join(os.path.dirname(path), file))
            if not os.path.exists(resolved):
                fail(f'{path}:{lineno}: link to `{target}`: {resolved} does not exist')
    begins = re.findall(r'<!-- figures:([\w-]+):begin -->', text)
    ends = re.findall(r'<!-- figures:([\w-]+):end -->', text)
    for name in sorted(set(begins) | set(ends)):
        b, e = begins.count(name), ends.count(name)
        if b != 1 or e != 1:
            fail(f'{path}: figures:{name} has {b} begin and {e} end markers (need one each)')
        elif text.index(f'<!-- figures:{name}:end -->') < text.index(f'<!-- figures:{name}:begin -->'):
            fail(f'{path}: figures:{name} ends before it begins')

if failed:
    sys.exit(1)
print(f'check-docs: README.md {n} lines; links in README.md and {len(sys.argv) - 2} docs resolve')
PY
