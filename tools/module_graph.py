#!/usr/bin/env python3
"""Prints the library modules' dependency graph as a Mermaid block for docs/ARCHITECTURE.md.

Reads every modules/*/CMakeLists.txt (relight_module(NAME x ... DEPS relight::y ... PRIVATE_DEPS ...)) and
draws the transitive reduction: an arrow x --> y when x uses y and no other dependency of x already does.

    python3 tools/module_graph.py      # from the repository root
"""
import glob
import re
import sys


def read_deps(root):
    deps = {}
    for path in sorted(glob.glob(f'{root}/modules/*/CMakeLists.txt')):
        text = open(path).read()
        m = re.search(r'relight_module\(NAME (\w+)(.*?)\)\n', text, re.S)
        if m:
            deps[m.group(1)] = set(re.findall(r'relight::(\w+)', m.group(2))) - {m.group(1)}
    return deps


def reachable(deps, start):
    seen, todo = set(), list(deps.get(start, ()))
    while todo:
        d = todo.pop()
        if d not in seen:
            seen.add(d)
            todo.extend(deps.get(d, ()))
    return seen


def main():
    root = sys.argv[1] if len(sys.argv) > 1 else '.'
    deps = read_deps(root)
    print('```mermaid')
    print('graph TD')
    for name in sorted(deps):
        direct = deps[name]
        implied = set().union(*(reachable(deps, d) for d in direct)) if direct else set()
        for d in sorted(direct - implied):
            print(f'  {name} --> {d}')
    print('```')


if __name__ == '__main__':
    main()
