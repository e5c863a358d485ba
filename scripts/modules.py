#!/usr/bin/env python3
"""The module map of src/ and the architecture rules it must keep.

Prints which top-level modules each module uses (`crate::X` paths), then checks: the core
modules keep the layer order of LAYERS (each uses only those above it; hence no cycle
between them), no import cycle between the modules of any folder (the
sibling files and subfolders of `src/accel/`, `src/accel/wbvh/`, ...: a `crate::`,
`super::` or `self::` path from anywhere below one sibling into another is an edge; a
folder's own `mod.rs` is the parent, not a sibling), no stage (src/stages/*.rs) using another stage
or tracing a single ray (the tracer's `occluded_one`; stages hand whole queues to it),
no file in src/ over 800 lines, no function in the driver (src/render/) over 60 lines,
no function with more than 6 parameters whose `allow(clippy::too_many_arguments)`
does not state its reason in a comment, and no queue column (a field of a `soa!` queue in
queue.rs) grown outside queue.rs (`.col.push(`, `.resize(`, `.extend(`...): queues grow by
whole entries, through the macro's pushes. Exit 1 on a violation.
Usage: scripts/modules.py [--graph]
"""
import os
import re
import sys

SRC = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "src")
MAX_LINES = 800
MAX_DRIVER_FN = 60
MAX_PARAMS = 6
# The renderer core, top to bottom (docs/architecture.md's module map): a module uses
# only the modules above it. The tools (src/tools/, src/cli/) may use any of them.
LAYERS = [
    "error", "color", "simd", "sampling", "film", "system", "bsdf", "motion", "texture", "emitter",
    "queue", "accel", "scene", "surface", "light", "stages", "stats", "render",
]


def functions(text):
    """(name, first line, lines, parameters, attribute lines above) of every fn with a body."""
    out = []
    lines = text.split("\n")
    for m in re.finditer(r"\bfn\s+(\w+)\s*(<[^(]*>)?\s*\(", text):
        i, depth = m.end(), 1
        while depth and i < len(text):
            depth += {"(": 1, ")": -1}.get(text[i], 0)
            i += 1
        params = text[m.end():i - 1]
        # Top-level commas only (closure and generic arguments have their own brackets).
        level, count, seen = 0, 0, False
        for ch in params:
            if ch in "(<[{":
                level += 1
            elif ch in ")>]}":
                level -= 1
            elif ch == "," and level == 0:
                count += 1
            if not ch.isspace():
                seen = True
        n = count + 1 if seen and not params.rstrip().endswith(",") else count
        if re.match(r"\s*&?\s*(mut\s+)?self\b", params):
            n -= 1
        brace = text.find("{", i)
        semi = text.find(";", i)
        if brace < 0 or (0 <= semi < brace):
            continue  # a declaration without a body
        j, depth = brace + 1, 1
        while depth and j < len(text):
            depth += {"{": 1, "}": -1}.get(text[j], 0)
            j += 1
        first = text.count("\n", 0, m.start())
        last = text.count("\n", 0, j)
        above = "\n".join(lines[max(0, first - 4):first])
        out.append((m.group(1), first + 1, last - first + 1, n, above))
    return out


def top_module(rel):
    """`render/meter.rs` -> `render`; `lib.rs`/`main.rs` -> None."""
    parts = rel[:-3].split(os.sep)
    if parts[0] in ("lib", "main"):
        return None
    return parts[0]


def code(text):
    """The text without comments and string literals (good enough for use paths)."""
    text = re.sub(r"//[^\n]*", "", text)
    return re.sub(r'"(\\.|[^"\\])*"', '""', text)


def module_path(rel):
    """`accel/wbvh/walk.rs` -> ["accel", "wbvh", "walk"]; `accel/wbvh/mod.rs` -> ["accel", "wbvh"]."""
    parts = rel[:-3].split(os.sep)
    if parts[-1] == "mod" or (len(parts) == 1 and parts[0] in ("lib", "main")):
        parts = parts[:-1]
    return parts


def referenced_paths(body, mp):
    """The absolute module paths (lists) a file's code names through crate::, super:: and self::."""
    out = []
    for m in re.finditer(r"\b((?:crate|self|super)(?:::super)*)::(\{[^}]*\}|\w+(?:::\w+)*(?:::\{[^}]*\})?)", body):
        head = m.group(1).split("::")
        base = [] if head[0] == "crate" else list(mp) if head[0] == "self" else list(mp[:-1])
        for _ in head[1:]:
            base = base[:-1]
        tail = m.group(2)
        prefix, _, group = tail.partition("{")
        prefix = [x for x in prefix.split("::") if x]
        if group:
            for item in group.rstrip("}").split(","):
                item = item.strip().split(" as ")[0]
                if item and item != "self":
                    out.append(base + prefix + [x for x in item.split("::") if x])
                elif item == "self":
                    out.append(base + prefix)
        else:
            out.append(base + prefix)
    return out


def is_module(path):
    """True when `path` (a list under src/) is a module file or folder."""
    p = os.path.join(SRC, *path)
    return bool(path) and (os.path.isfile(p + ".rs") or os.path.isdir(p))


def folder_cycles(files):
    """Import cycles among the sibling modules of every folder below src/ (the top level
    is checked on its own). `files`: (rel path, code) pairs."""
    edges = {}
    for rel, body in files:
        mp = module_path(rel)
        for tp in referenced_paths(body, mp):
            k = 0
            while k < min(len(mp), len(tp)) and mp[k] == tp[k]:
                k += 1
            if k == 0 or k >= len(mp) or k >= len(tp) or not is_module(tp[: k + 1]):
                continue
            edges.setdefault(tuple(mp[:k]), {}).setdefault(mp[k], set()).add(tp[k])
    return [
        "/".join(folder) + ": " + " -> ".join(c) for folder, graph in sorted(edges.items()) for c in find_cycles(graph)
    ]


def find_cycles(graph):
    """The cycles a depth-first search meets in `graph` (node -> set of nodes), each as the
    list of its nodes with the first repeated at the end."""
    cycles, state, stack = [], {}, []

    def visit(m):
        state[m] = "open"
        stack.append(m)
        for d in sorted(graph.get(m, ())):
            if state.get(d) == "open":
                cycles.append(stack[stack.index(d):] + [d])
            elif d not in state:
                visit(d)
        stack.pop()
        state[m] = "done"

    for m in sorted(graph):
        if m not in state:
            visit(m)
    return cycles


QUEUE_GROWS = r"\.({})\.(push|resize|extend|extend_from_slice|insert|append|truncate)\("


def queue_columns():
    """The column names of the `soa!` queues of queue.rs that no other struct in src/ also
    uses as a `Vec` field name (those could not be told apart by name)."""
    text = open(os.path.join(SRC, "queue.rs"), encoding="utf-8").read()
    cols = set()
    for block in re.findall(r"soa! \{(.*?)\n\}", text, re.S):
        body = block.split("push(")[0] + "".join(re.findall(r"sparse\((.*?)\)", block, re.S))
        cols |= set(re.findall(r"^\s*(\w+)\s*:", body, re.M))
    other = set()
    for root, _, files in os.walk(SRC):
        for f in files:
            if f.endswith(".rs") and not (root == SRC and f == "queue.rs"):
                other |= set(re.findall(r"\b(\w+)\s*:\s*Vec<", open(os.path.join(root, f), encoding="utf-8").read()))
    return sorted(cols - other)


def main():
    uses, stage_uses, long_files, long_fns, single_rays = {}, [], [], [], []
    grows = re.compile(QUEUE_GROWS.format("|".join(queue_columns())))
    hand_pushes = []
    all_files = []
    stages = {f[:-3] for f in os.listdir(os.path.join(SRC, "stages")) if f.endswith(".rs") and f != "mod.rs"}
    for root, _, files in os.walk(SRC):
        for f in sorted(files):
            if not f.endswith(".rs"):
                continue
            path = os.path.join(root, f)
            rel = os.path.relpath(path, SRC)
            text = open(path, encoding="utf-8").read()
            if text.count("\n") > MAX_LINES:
                long_files.append((rel, text.count("\n")))
            body = code(text.split("#[cfg(test)]")[0])
            all_files.append((rel, body))
            for name, line, length, params, above in functions(body):
                if rel.startswith("render" + os.sep) and length > MAX_DRIVER_FN:
                    long_fns.append(f"{rel}:{line}: fn {name} is {length} lines (driver limit {MAX_DRIVER_FN})")
                raw_above = "\n".join(text.split("\n")[max(0, line - 5):line - 1])
                if params > MAX_PARAMS and not re.search(r"too_many_arguments\)\]\s*//\s*\S", raw_above):
                    long_fns.append(f"{rel}:{line}: fn {name} has {params} parameters and no stated reason")
            if rel != "queue.rs":
                for m in grows.finditer(body):
                    line = body.count("\n", 0, m.start()) + 1
                    hand_pushes.append(f"{rel}:{line}: queue column `{m.group(1)}` grown by hand ({m.group(2)}): push whole entries (soa!)")
            mod = top_module(rel)
            if mod is None:
                continue
            deps = set(re.findall(r"\bcrate::(\w+)", body))
            # `use crate::{a, b::c}` groups.
            for group in re.findall(r"\bcrate::\{([^}]*)\}", body):
                deps |= {p.strip().split("::")[0] for p in group.split(",") if p.strip()}
            deps.discard(mod)
            deps.discard("Error")
            deps.discard("Result")
            uses.setdefault(mod, set()).update(d for d in deps if os.path.exists(os.path.join(SRC, d + ".rs")) or os.path.isdir(os.path.join(SRC, d)))
            if rel.startswith("stages" + os.sep) and f != "mod.rs":
                me = f[:-3]
                others = set(re.findall(r"\bcrate::stages::(\w+)", body)) | set(re.findall(r"\bsuper::(\w+)", body))
                for group in re.findall(r"\bcrate::stages::\{([^}]*)\}", body):
                    others |= {p.strip().split("::")[0] for p in group.split(",") if p.strip()}
                for o in sorted(others & stages - {me}):
                    stage_uses.append((me, o))
                if re.search(r"\boccluded_one\b", body):
                    single_rays.append(me)

    if "--graph" in sys.argv:
        for m in sorted(uses):
            print(f"{m:10} -> {', '.join(sorted(uses[m])) or '(nothing)'}")

    ok = True
    for m in sorted(uses):
        if m not in LAYERS and m not in ("tools", "cli"):
            print(f"module `{m}` is in no layer of LAYERS (scripts/modules.py, docs/architecture.md)")
            ok = False
        for d in sorted(uses[m]):
            if m in LAYERS and (d not in LAYERS or LAYERS.index(d) >= LAYERS.index(m)):
                print(f"layer order: `{m}` uses `{d}`, which is not above it (LAYERS)")
                ok = False
    for c in find_cycles(uses):
        print("import cycle: " + " -> ".join(c))
        ok = False
    for c in folder_cycles(all_files):
        print("import cycle inside " + c)
        ok = False
    for a, b in stage_uses:
        print(f"stage `{a}` uses stage `{b}`")
        ok = False
    for me in single_rays:
        print(f"stage `{me}` traces a single ray (occluded_one): queue the rays and trace the queue")
        ok = False
    for msg in hand_pushes:
        print(msg)
        ok = False
    for msg in long_fns:
        print(msg)
        ok = False
    for rel, n in long_files:
        print(f"{rel}: {n} lines (over {MAX_LINES})")
        ok = False
    if ok:
        print(
            f"modules ok: {len(uses)} top-level modules in layer order, no cycle inside a folder, no stage using another or tracing a single ray, "
            f"no queue column grown outside queue.rs, "
            f"no file over {MAX_LINES} "
            f"lines, no driver function over {MAX_DRIVER_FN} lines, no unexplained parameter list over {MAX_PARAMS}"
        )
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
