"""The C++ tree keeps its shape (docs/development.md, "Layout"): no folder includes one above it, and no function
is longer than scripts/lib/check_sources.py allows. The checker itself is tested on made-up sources."""
import os
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, 'scripts', 'lib'))

import check_sources  # noqa: E402


def test_no_folder_includes_a_folder_above_it():
    assert check_sources.include_findings() == []


def test_no_function_is_longer_than_the_limit():
    rows = check_sources.long_functions(check_sources.MAX_FUNCTION_LINES)
    assert rows == [], '\n'.join('%s:%d %s: %d lines' % (rel, line, name, n) for n, rel, line, name in rows)


def test_functions_are_measured_from_signature_to_closing_brace():
    text = '\n'.join([
        'namespace a',
        '{',
        'struct S',
        '{',
        '  int f() const',      # line 5
        '  {',
        '    return 1;',
        '  }',                  # line 8
        '};',
        'int g(int x,',         # line 10
        '      int y)',
        '{',
        '  const char* s = "{ not a brace";',
        '  // } nor this',
        '  for (int i = 0; i < x; ++i)',
        '  {',
        '    y += i;',
        '  }',
        '  auto l = [&]() { return y; };',
        '  return l();',
        '}',                    # line 21
        '}  // namespace a',
    ])
    assert check_sources.functions(text) == [(5, 8, 'f'), (10, 21, 'g')]


def test_an_upward_include_is_found(tmp_path, monkeypatch):
    for rel, body in [('src/core/filter/x.cpp', '#include "rbpf_slam/core/grid/y.h"\n'),
                      ('src/core/grid/y.cpp', '#include "rbpf_slam/core/filter/x.h"\n')]:
        path = tmp_path / rel
        path.parent.mkdir(parents=True)
        path.write_text(body)
    monkeypatch.setattr(check_sources, 'ROOT', str(tmp_path))
    findings = check_sources.include_findings()
    assert len(findings) == 1 and findings[0].startswith('src/core/filter/x.cpp:1: core/filter includes core/grid')
