#!/usr/bin/env python3
"""Check the relative links of README.md and doc/*.md.

Every `](target)` whose target is not a URL must name an existing file (relative to the
page). A `#anchor` must be a heading of the target page, slugged as GitHub does (lower
case; letters, marks, decimal digits, '_', '-' and spaces kept, spaces turned into '-';
a repeated slug gets -1, -2, ...). Headings inside ``` fences are not headings.

usage: python3 test/check_doc_links.py [--pending FILE ...]
  --pending: files that other branches are writing; links to them are listed, not failed.
Exit status 0 when every link resolves, 1 otherwise.
"""
import glob
import os
import re
import sys
import unicodedata

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
LINK = re.compile(r'\]\(([^()\s]*)\)')


def slug(text):
    text = re.sub(r'`', '', text).strip().lower()
    kept = [c for c in text
            if c in ' -_' or unicodedata.category(c)[0] in 'LM' or unicodedata.category(c) == 'Nd']
    return ''.join(kept).replace(' ', '-')


def anchors(path):
    seen, out, fence = {}, set(), False
    for line in open(path, encoding='utf-8'):
        if line.lstrip().startswith('```'):
            fence = not fence
            continue
        m = None if fence else re.match(r'#{1,6}\s+(.*?)\s*#*\s*$', line)
        if m:
            s = slug(m.group(1))
            n = seen.get(s, 0)
            seen[s] = n + 1
            out.add(s if n == 0 else f'{s}-{n}')
    return out


def main(argv):
    pending = set()
    if argv[:1] == ['--pending']:
        pending = {os.path.normpath(os.path.join(ROOT, p)) for p in argv[1:]}
    pages = [os.path.join(ROOT, 'README.md')] + sorted(glob.glob(os.path.join(ROOT, 'doc', '*.md')))
    bad, waiting, count = [], [], 0
    for page in pages:
        text = open(page, encoding='utf-8').read()
        # links inside code spans and fences are not links
        text = re.sub(r'```.*?```', '', text, flags=re.S)
        text = re.sub(r'`[^`\n]*`', '', text)
        for target in LINK.findall(text):
            if re.match(r'[a-z]+:', target):
                continue
            count += 1
            file_part, _, anchor = target.partition('#')
            dest = os.path.normpath(os.path.join(os.path.dirname(page), file_part)) if file_part else page
            where = f'{os.path.relpath(page, ROOT)}: ({target})'
            if not os.path.exists(dest):
                (waiting if dest in pending else bad).append(where + ': no such file')
            elif anchor and dest.endswith('.md') and anchor not in anchors(dest):
                bad.append(where + f': no heading #{anchor} in {os.path.relpath(dest, ROOT)}')
    for w in waiting:
        print('pending:', w)
    for b in bad:
        print('BROKEN: ', b)
    print(f'{count} relative links in {len(pages)} pages: {len(bad)} broken, {len(waiting)} to pending pages')
    return 1 if bad else 0


if __name__ == '__main__':
    sys.exit(main(sys.argv[1:]))
