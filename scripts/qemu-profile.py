#!/usr/bin/env python3
"""Instruction profile of the QEMU firmware replay (issue 4): where the per-sample instructions go.

Usage (from the workspace root):
    cargo test -p aerosid-host --test integration qemu_replay::write_profile_replay -- --ignored
    cargo test -p aerosid-host --test integration qemu_replay::qemu_replay_equals   # builds target/qemu
    python3 scripts/qemu-profile.py [--inlined] [--top N]

Runs the QEMU build of the firmware on target/qemu-prof/replay.bin with `-singlestep -d exec,nochain`
(one log line per executed guest instruction: each translated block is one instruction), counts
executions per PC and attributes them to functions: by the ELF symbol table (outermost, not-inlined
function) and, with --inlined, by llvm-symbolizer's innermost inlined frame and source line.
"""
import collections, os, re, subprocess, sys, glob

root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
elf = os.path.join(root, "target/qemu/thumbv7em-none-eabihf/release/aerosid-firmware")
prof = os.path.join(root, "target/qemu-prof")
top = 40
if "--top" in sys.argv:
    top = int(sys.argv[sys.argv.index("--top") + 1])
tools = glob.glob(os.path.expanduser("~/.rustup/toolchains/*/lib/rustlib/*/bin"))
def tool(name):
    for t in tools:
        p = os.path.join(t, name)
        if os.path.exists(p):
            return p
    return name

log = os.path.join(prof, "exec.log")
subprocess.run(["qemu-system-arm", "-machine", "netduinoplus2", "-nographic", "-monitor", "none",
                "-serial", "null", "-semihosting-config", "enable=on,target=native",
                "-icount", "shift=0,align=off,sleep=off", "-singlestep",
                "-d", "exec,nochain", "-D", log, "-kernel", elf],
               cwd=prof, stdout=subprocess.DEVNULL, check=False)
counts = collections.Counter()
pat = re.compile(r"Trace [^:]*: [0-9a-fx]+ \[[0-9a-f]+/([0-9a-f]+)/")
with open(log) as f:
    for line in f:
        m = pat.match(line)
        if m:
            counts[int(m.group(1), 16) & ~1] += 1
total = sum(counts.values())
# Symbols (functions) by address.
syms = []
out = subprocess.run([tool("llvm-nm"), "-S", "--defined-only", "--demangle", elf], capture_output=True, text=True).stdout
for line in out.splitlines():
    parts = line.split(None, 3)
    if len(parts) == 4 and parts[2].lower() == "t":
        a, s = int(parts[0], 16) & ~1, int(parts[1], 16)
        syms.append((a, a + s, parts[3]))
syms.sort()
import bisect
starts = [s[0] for s in syms]
byfn = collections.Counter()
for pc, n in counts.items():
    i = bisect.bisect_right(starts, pc) - 1
    name = syms[i][2] if i >= 0 and pc < syms[i][1] else "?"
    byfn[re.sub(r"::h[0-9a-f]{16}$", "", name)] += n
print(f"{total} instructions executed")
print("by function (not inlined):")
for name, n in byfn.most_common(top):
    print(f"{n:10d} {100.0*n/total:5.1f}%  {name[:150]}")
if "--inlined" in sys.argv:
    pcs = sorted(counts)
    r = subprocess.run(["llvm-symbolizer", "--obj=" + elf, "--inlining", "--functions=short"],
                       input="\n".join(hex(p) for p in pcs), capture_output=True, text=True).stdout
    blocks = r.strip().split("\n\n")
    byinl = collections.Counter(); byline = collections.Counter()
    for pc, b in zip(pcs, blocks):
        lines = b.splitlines()
        fn = lines[0] if lines else "?"
        loc = lines[1] if len(lines) > 1 else "?"
        # Attribute to the innermost frame in our own code (not core::ops / nalgebra glue).
        for i in range(0, len(lines) - 1, 2):
            if "/work/" in lines[i + 1] or "aerosid" in lines[i + 1]:
                fn, loc = lines[i], lines[i + 1]
                break
        byinl[fn] += counts[pc]
        byline[(fn, re.sub(r"^.*/(core|firmware|src)/", r"\1/", loc))] += counts[pc]
    print("by innermost inlined function:")
    for name, n in byinl.most_common(top):
        print(f"{n:10d} {100.0*n/total:5.1f}%  {name[:150]}")
    print("by source line:")
    for (fn, loc), n in byline.most_common(top):
        print(f"{n:10d} {100.0*n/total:5.1f}%  {loc[:90]}  {fn[:60]}")
