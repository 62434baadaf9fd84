#!/usr/bin/env python3
"""Lists the functions in src/ longer than a limit (default 100 lines), longest first.

A function's length runs from its `fn` line to its closing brace, counted by brace depth with
string literals, char literals and comments skipped. Usage: scripts/long-functions.py [LIMIT] [DIR]
"""
import os, re, sys

limit = int(sys.argv[1]) if len(sys.argv) > 1 else 100
root = sys.argv[2] if len(sys.argv) > 2 else "src"
fn_re = re.compile(r'^\s*(pub(\([^)]*\))?\s+)?(const\s+)?(async\s+)?(unsafe\s+)?fn\s+(\w+)')

def strip(line, state):
    """The line with strings, chars and comments blanked; state carries block comments/strings."""
    out, i = [], 0
    while i < len(line):
        c = line[i]
        if state['block']:
            if line.startswith('*/', i): state['block'] = False; i += 2
            else: i += 1
            continue
        if state['str']:
            if c == '\\': i += 2; continue
            if c == '"': state['str'] = False
            i += 1; continue
        if line.startswith('//', i): break
        if line.startswith('/*', i): state['block'] = True; i += 2; continue
        if c == '"': state['str'] = True; i += 1; continue
        m = re.match(r"'(\\.|[^\\'])'", line[i:])
        if m: i += len(m.group(0)); continue
        out.append(c); i += 1
    return ''.join(out)

found = []
for dirpath, _, files in os.walk(root):
    for f in files:
        if not f.endswith('.rs'): continue
        path = os.path.join(dirpath, f)
        lines = open(path, encoding='utf-8').read().split('\n')
        state = {'block': False, 'str': False}
        stack = []  # (name, start, depth_at_open)
        depth = 0
        pending = None
        for n, line in enumerate(lines, 1):
            m = fn_re.match(line) if not state['block'] and not state['str'] else None
            code = strip(line, state)
            if m: pending = (m.group(6), n)
            for c in code:
                if c == '{':
                    depth += 1
                    if pending: stack.append((pending[0], pending[1], depth)); pending = None
                elif c == '}':
                    if stack and stack[-1][2] == depth:
                        name, start, _ = stack.pop()
                        length = n - start + 1
                        if length > limit: found.append((length, path, start, name))
                    depth -= 1
            if pending and code.rstrip().endswith(';'): pending = None
for length, path, start, name in sorted(found, reverse=True):
    print(f"{length:5d}  {path}:{start}  {name}")
