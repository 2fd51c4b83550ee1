#!/usr/bin/env python3
"""Checks the C++ tree's shape (docs/development.md, "Layout"): no folder includes a folder above it, and no
function is longer than a reader can hold.

    python3 scripts/lib/check_sources.py            # both checks; exit 1 and a line per finding on failure
    python3 scripts/lib/check_sources.py --longest 20   # the 20 longest functions, for planning
"""
import argparse
import os
import re
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

# What each folder of src/ and include/rbpf_slam/ may include of the package (besides itself). Core folders are
# ROS-free and stacked: filter at the bottom; grid and extraction on it; fastslam on extraction; forest_map on
# fastslam; trunk_slam, the pipeline, on all of them.
MAY_INCLUDE = {
    'core/filter': set(),
    'core/grid': {'core/filter'},
    'core/extraction': {'core/filter'},
    'core/fastslam': {'core/filter', 'core/extraction'},
    'core/forest_map': {'core/filter', 'core/extraction', 'core/fastslam'},
    'core/trunk_slam': {'core/filter', 'core/extraction', 'core/fastslam', 'core/forest_map'},
}
CORE = set(MAY_INCLUDE)
MAY_INCLUDE.update({
    'io': CORE,
    'sim': CORE | {'io'},
    'eval': CORE | {'io', 'sim'},
    'replay': CORE | {'io', 'ros'},
})
MAX_FUNCTION_LINES = 120
INCLUDE = re.compile(r'^\s*#\s*include\s*"rbpf_slam/([a-z_]+(?:/[a-z_]+)?)/[A-Za-z0-9_]+\.h"', re.M)


def folder_of(rel):
    """'src/core/grid/x.cpp' -> 'core/grid'; 'include/rbpf_slam/io/x.h' -> 'io'."""
    parts = rel.split('/')
    parts = parts[2:] if parts[0] == 'include' else parts[1:]
    if parts and parts[0] == 'core' and len(parts) > 2:
        return 'core/' + parts[1]
    return parts[0] if len(parts) > 1 else ''


def sources(subdirs=('src', 'include')):
    for sub in subdirs:
        for d, dirs, names in os.walk(os.path.join(ROOT, sub)):
            dirs.sort()
            for name in sorted(names):
                if name.endswith(('.h', '.hpp', '.cpp', '.cc')):
                    yield os.path.relpath(os.path.join(d, name), ROOT)


def include_findings():
    out = []
    for rel in sources():
        folder = folder_of(rel)
        if folder not in MAY_INCLUDE:
            continue
        with open(os.path.join(ROOT, rel), encoding='utf-8', errors='replace') as f:
            text = f.read()
        for m in INCLUDE.finditer(text):
            target = m.group(1)
            target = target if target.startswith('core/') else target.split('/')[0]
            if target != folder and target not in MAY_INCLUDE[folder]:
                line = text.count('\n', 0, m.start()) + 1
                out.append('%s:%d: %s includes %s, which is not below it' % (rel, line, folder, target))
    return out


def strip_code(src):
    """The source with comments, string and character literals and preprocessor lines blanked (lines kept)."""
    out = []
    i, n = 0, len(src)
    while i < n:
        if src.startswith('//', i):
            j = src.find('\n', i)
            i = n if j < 0 else j
            continue
        if src.startswith('/*', i):
            j = src.find('*/', i + 2)
            j = n if j < 0 else j + 2
            out.append('\n' * src.count('\n', i, j))
            i = j
            continue
        m = re.match(r'R"([^(\s]*)\(', src[i:i + 20]) if src.startswith('R"', i) else None
        if m:
            end = ')' + m.group(1) + '"'
            j = src.find(end, i)
            j = n if j < 0 else j + len(end)
            out.append('""' + '\n' * src.count('\n', i, j))
            i = j
            continue
        c = src[i]
        if c == "'" and i > 0 and src[i - 1].isalnum():  # a digit separator (1'000)
            out.append(' ')
            i += 1
            continue
        if c in '"\'':
            j = i + 1
            while j < n and src[j] != c and src[j] != '\n':
                j += 2 if src[j] == '\\' else 1
            out.append(c + c)
            i = j + 1
            continue
        out.append(c)
        i += 1
    return re.sub(r'^[ \t]*#.*$', '', ''.join(out), flags=re.M)


SCOPE_HEAD = re.compile(r'^(namespace|class|struct|union|enum|extern)\b')
TYPE_HEAD = re.compile(r'\b(class|struct|union)\s+\w+[^()]*$')


def functions(text):
    """(first line, last line, name) of every function body outside another function in C++ source @p text."""
    s = strip_code(text)
    stack = []  # 'scope' (namespace, class), 'func' with its start line, or 'other'
    found = []
    last = 0
    for i, c in enumerate(s):
        if c not in ';{}':
            continue
        if c == '{':
            head = s[last:i]
            kind, start = 'other', 0
            if all(k == 'scope' for k, _ in stack):
                h = head.strip()
                if SCOPE_HEAD.match(h) or TYPE_HEAD.search(h):
                    kind = 'scope'
                elif '(' in h and not h.endswith('='):
                    kind = 'func'
                    start = s.count('\n', 0, last + len(head) - len(head.lstrip())) + 1
            stack.append((kind, start))
        elif c == '}' and stack:
            kind, start = stack.pop()
            if kind == 'func':
                found.append((start, s.count('\n', 0, i) + 1))
        last = i + 1
    lines = text.split('\n')
    named = []
    for a, b in found:
        signature = ' '.join(l.strip() for l in lines[a - 1:a + 2])
        m = re.search(r'([\w:~]+)\s*\(', signature)
        named.append((a, b, m.group(1) if m else signature[:40]))
    return named


def long_functions(limit):
    rows = []
    for rel in sources(('src', 'include', 'nodes')):
        with open(os.path.join(ROOT, rel), encoding='utf-8', errors='replace') as f:
            text = f.read()
        for a, b, name in functions(text):
            if b - a + 1 > limit:
                rows.append((b - a + 1, rel, a, name))
    return sorted(rows, reverse=True)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--longest', type=int, metavar='N', help='list the N longest functions and exit')
    args = parser.parse_args()
    if args.longest:
        for lines, rel, line, name in long_functions(0)[:args.longest]:
            print('%4d lines  %s:%d  %s' % (lines, rel, line, name))
        return 0
    findings = include_findings()
    findings += ['%s:%d: %s is %d lines (at most %d)' % (rel, line, name, lines, MAX_FUNCTION_LINES)
                 for lines, rel, line, name in long_functions(MAX_FUNCTION_LINES)]
    for f in findings:
        print(f)
    print('check_sources: %d finding(s)' % len(findings))
    return 1 if findings else 0


if __name__ == '__main__':
    sys.exit(main())
