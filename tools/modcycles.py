#!/usr/bin/env python3
"""Pairs of files of one crate that import each other (issue 35 item 5, "circles"): file A
uses an item defined in file B and B one defined in A (`use crate::…`, `use super::…`,
`use self::…`, a child module's name, or such a path written in the code). Imports are
followed through re-exports to the file that defines the item; a `pub use` re-export alone
(a module's facade) is not an import; `#[cfg(test)]` modules are left out.

Usage: python3 tools/modcycles.py [ROOT]  — prints one line per pair; exit 1 if any."""
import os, re, sys, itertools
ROOT = sys.argv[1] if len(sys.argv) > 1 else '.'

def crates():
    for root, dirs, files in os.walk(ROOT):
        dirs[:] = [d for d in dirs if d not in ('target', '.git', 'node_modules', 'fuzz', 'tests', 'benches', 'examples')]
        if 'Cargo.toml' in files and os.path.isdir(os.path.join(root, 'src')):
            yield root

def modules(src):
    m = {}
    for root, dirs, files in os.walk(src):
        for f in files:
            if not f.endswith('.rs'): continue
            p = os.path.join(root, f)
            rel = os.path.relpath(p, src)[:-3].split(os.sep)
            if rel[0] == 'bin': continue
            if rel in (['lib'], ['main']): key = ()
            elif rel[-1] == 'mod': key = tuple(rel[:-1])
            else: key = tuple(rel)
            m.setdefault(key, p)
    return m

def clean(text):
    text = re.sub(r'//[^\n]*', '', text)
    text = re.sub(r'/\*.*?\*/', '', text, flags=re.S)
    text = re.sub(r'"(\\.|[^"\\])*"', '""', text)
    return text.split('#[cfg(test)]')[0]

def expand(u):
    i = u.find('{')
    if i < 0: return [u]
    depth = 0; parts = []; cur = ''
    for ch in u[i+1:u.rfind('}')]:
        if ch == '{': depth += 1
        if ch == '}': depth -= 1
        if ch == ',' and depth == 0: parts.append(cur); cur = ''
        else: cur += ch
    parts.append(cur)
    res = []
    for p in parts:
        p = p.strip(" §")
        if p == '': continue
        if p == 'self': res.append(u[:i].rstrip(':')); continue
        res += expand(u[:i] + p)
    return res

USE = re.compile(r'(?m)^\s*(pub(?:\([^)]*\))?\s+)?use\s+([^;]+);')
DEF = re.compile(r'(?m)^\s*(?:pub(?:\([^)]*\))?\s+)?(?:unsafe\s+|const\s+|async\s+|extern\s+"C"\s+)*(?:fn|struct|enum|trait|type|const|static|union|mod|macro_rules!)\s+([A-Za-z_]\w*)')

class Crate:
    def __init__(self, src):
        self.mods = modules(src)
        self.defs = {}; self.uses = {}
        for k, f in self.mods.items():
            t = clean(open(f, errors='ignore').read())
            self.defs[k] = set(DEF.findall(t))
            us = []
            for m in USE.finditer(t):
                for p in expand(re.sub(r'\s+', ' ', m.group(2)).replace(' ', '§')):
                    p = p.replace('§', ' ').strip()
                    alias = None
                    if ' as ' in p: p, alias = [x.strip() for x in p.split(' as ')]
                    segs = [s for s in p.split('::') if s]
                    if segs:
                        us.append((bool(m.group(1)), segs, alias or segs[-1]))
            # paths written in the code (`crate::a::B::new()`, `super::f(…)`): uses too
            body = USE.sub('', t)
            for m in re.finditer(r'(?<![\w:])((?:crate|super|self)(?:::[A-Za-z_]\w*)+)', body):
                segs = m.group(1).split('::')
                us.append((False, segs, segs[-1]))
            self.uses[k] = us

    def start(self, here, segs):
        if segs[0] == 'crate': return (), segs[1:]
        if segs[0] == 'super':
            b = here
            while segs and segs[0] == 'super': b, segs = b[:-1], segs[1:]
            return b, segs
        if segs[0] == 'self': return here, segs[1:]
        if here + (segs[0],) in self.mods: return here, segs
        return None, None

    def target(self, here, segs, seen=()):
        """The file (module key) that defines what `segs` names, seen from `here`."""
        base, rest = self.start(here, segs)
        if base is None: return None
        while rest and base + (rest[0],) in self.mods:
            base, rest = base + (rest[0],), rest[1:]
        if not rest or rest == ['*']: return base
        name = rest[0]
        if len(rest) > 1:  # an enum variant, associated item…: the enum's file
            pass
        if name in self.defs[base]: return base
        if (base, name) in seen: return base
        for _, s, alias in self.uses[base]:
            if alias == name or s[-1] == '*':
                t = self.target(base, s if alias == name else s[:-1] + [name], seen + ((base, name),))
                if t is not None and (alias == name or name in self.defs.get(t, ())):
                    return t
        return base

def main():
    found = []
    for c in sorted(crates()):
        cr = Crate(os.path.join(c, 'src'))
        edges = {}
        for k in cr.mods:
            for pub, segs, _ in cr.uses[k]:
                if pub: continue  # a facade re-export, not a use
                t = cr.target(k, segs)
                if t is not None and t != k:
                    edges.setdefault(k, set()).add(t)
        for a, b in itertools.combinations(sorted(cr.mods), 2):
            if b in edges.get(a, ()) and a in edges.get(b, ()):
                kind = 'parent-child' if (a == b[:-1] or b == a[:-1]) else 'siblings'
                found.append((kind, os.path.relpath(cr.mods[a], ROOT), os.path.relpath(cr.mods[b], ROOT)))
    for k, a, b in found:
        print(f'{k:13} {a} <-> {b}')
    return found

if __name__ == '__main__':
    sys.exit(1 if main() else 0)
