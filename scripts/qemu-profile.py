#!/usr/bin/env python3
"""Instruction profile of the QEMU firmware replay: where the per-sample instructions go.

Usage (from the workspace root):
    cargo test -p aerosid-host-tests --test integration qemu_replay::write_profile_replay -- --ignored
    cargo test -p aerosid-host-tests --test integration qemu_replay::qemu_replay_equals   # builds target/qemu
    python3 scripts/qemu-profile.py [--inlined] [--classes [--minus M]] [--top N]

Runs the QEMU build of the firmware on target/qemu-prof/replay.bin with `-singlestep -d exec,nochain`
(one log line per executed guest instruction: each translated block is one instruction), counts
executions per PC and attributes them to functions: by the ELF symbol table (outermost, not-inlined
function) and, with --inlined, by llvm-symbolizer's innermost inlined frame and source line.

--classes sorts the executed instructions into classes by mnemonic (llvm-objdump): floating-point
arithmetic, floating-point compares and flag moves, floating-point loads, stores and register moves,
integer loads and stores, branches, other integer instructions — for the estimators' own code (the
source files of the six estimators: gtls.rs, linalg/, vff.rs, estimator.rs, scalar.rs but for the
synthesis's sin_cos_f32, by the innermost inlined frame; also split by file) and for everything,
per sample of the profiled replay. The floating-point arithmetic of the estimators is the part no
compiler or scheduling can remove: the operation count of the algorithm as compiled
(docs/benchmarks.md, "The floor, measured"). The replay starts the
estimators afresh, so its first samples run the start-up path; for the steady state profile two
lengths and take the difference: each --classes run saves its totals as
target/qemu-prof/classes-N.json, and --minus M prints (run of N − run of M)/(N − M):
    AEROSID_PROFILE_SAMPLES=60 cargo test -p aerosid-host-tests --test integration qemu_replay::write_profile_replay -- --ignored
    AEROSID_PROFILE_SAMPLES=60 python3 scripts/qemu-profile.py --classes
    AEROSID_PROFILE_SAMPLES=180 cargo test … (as above)
    AEROSID_PROFILE_SAMPLES=180 python3 scripts/qemu-profile.py --classes --minus 60
"""
import collections, json, os, re, subprocess, sys, glob

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

def ours(loc):
    """Whether a source location (llvm-symbolizer's `file:line:column`) is this workspace's code,
    wherever the checkout lives: under the root this script runs from or, for an image built in
    another checkout, a path through `core/src`, `firmware/src` or `firmware/step` that is not a
    dependency's (cargo's registry and git checkouts, the standard library's `/rustc/...`)."""
    if loc.startswith(root + os.sep):
        return True
    if "/.cargo/" in loc or loc.startswith("/rustc/"):
        return False
    return re.search(r"(^|/)(core/src|firmware/src|firmware/step)/", loc) is not None

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
            if ours(lines[i + 1]):
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

if "--classes" in sys.argv:
    # Mnemonic of every instruction in the image.
    dis = subprocess.run([tool("llvm-objdump"), "-d", "--no-show-raw-insn", elf], capture_output=True, text=True).stdout
    mnem = {}
    ins = re.compile(r"^\s*([0-9a-f]+):\s+([a-z][a-z0-9.]*)")
    for line in dis.splitlines():
        m = ins.match(line)
        if m:
            mnem[int(m.group(1), 16)] = m.group(2)
    def klass(op):
        base = op.split(".")[0]
        if base in ("vadd", "vsub", "vmul", "vnmul", "vdiv", "vsqrt", "vmla", "vmls", "vnmla", "vnmls",
                    "vfma", "vfms", "vfnma", "vfnms", "vneg", "vabs", "vcvt", "vcvtr", "vrint", "vrintm",
                    "vrintp", "vrintz", "vrintn", "vrinta", "vmaxnm", "vminnm") or base.startswith("vsel"):
            return "fp arithmetic"
        if base in ("vcmp", "vcmpe", "vmrs"):
            return "fp compare, flags"
        if base in ("vldr", "vstr", "vldmia", "vldmdb", "vstmia", "vstmdb", "vpush", "vpop", "vmov", "vmsr"):
            return "fp load, store, move"
        if re.match(r"^(ldr|str|ldm|stm|push|pop|ldrd|strd)", base):
            return "int load, store"
        if re.match(r"^(b|bl|blx|bx|cbz|cbnz|tbb|tbh|it[te]{0,3})$", base) or \
                re.match(r"^b(eq|ne|cs|hs|cc|lo|mi|pl|vs|vc|hi|ls|ge|lt|gt|le|al)$", base):
            return "branch, IT"
        return "int other"
    if "--inlined" not in sys.argv:
        pcs = sorted(counts)
        r = subprocess.run(["llvm-symbolizer", "--obj=" + elf, "--inlining", "--functions=short"],
                           input="\n".join(hex(p) for p in pcs), capture_output=True, text=True).stdout
        blocks = r.strip().split("\n\n")
    est_files = re.compile(r"core/src/(gtls\.rs|linalg/|vff\.rs|estimator\.rs|scalar\.rs)")
    est = collections.Counter(); whole = collections.Counter(); est_fp = collections.Counter()
    by_file = collections.Counter()  # (source file, class) of the estimators' instructions
    for pc, b in zip(pcs, blocks):
        op = mnem.get(pc, "?")
        k = klass(op)
        whole[k] += counts[pc]
        lines = b.splitlines()
        fn, loc = "?", "?"
        for i in range(0, len(lines) - 1, 2):
            if ours(lines[i + 1]):
                fn, loc = lines[i], lines[i + 1]
                break
        # scalar.rs also holds the synthesis's sin_cos_f32: not the estimators'.
        if est_files.search(loc) and not fn.startswith("sin_cos"):
            est[k] += counts[pc]
            src = re.search(r"core/src/([a-z_/]+\.rs)", loc).group(1)
            by_file[src + "|" + k] += counts[pc]
            if k == "fp arithmetic":
                est_fp[op] += counts[pc]
    unknown = sum(n for pc, n in counts.items() if pc not in mnem)
    if unknown:
        print(f"warning: {unknown} executed instructions at addresses llvm-objdump did not list", file=sys.stderr)
    samples = int(os.environ.get("AEROSID_PROFILE_SAMPLES", "60"))
    with open(os.path.join(prof, f"classes-{samples}.json"), "w") as f:
        json.dump({"estimators": est, "everything": whole, "fp": est_fp, "by_file": by_file}, f)
    label = f"{samples} samples"
    if "--minus" in sys.argv:
        base = int(sys.argv[sys.argv.index("--minus") + 1])
        with open(os.path.join(prof, f"classes-{base}.json")) as f:
            b = json.load(f)
        est = collections.Counter({k: v - b["estimators"].get(k, 0) for k, v in est.items()})
        whole = collections.Counter({k: v - b["everything"].get(k, 0) for k, v in whole.items()})
        est_fp = collections.Counter({k: v - b["fp"].get(k, 0) for k, v in est_fp.items()})
        by_file = collections.Counter({k: v - b.get("by_file", {}).get(k, 0) for k, v in by_file.items()})
        label = f"samples {base + 1}-{samples} of the profile replay: the run of {samples} minus the run of {base}"
        samples -= base
    order = ["fp arithmetic", "fp compare, flags", "fp load, store, move", "int load, store", "branch, IT", "int other"]
    print(f"by instruction class, per sample ({label}):")
    print(f"{'class':24s} {'estimators':>12s} {'share':>6s} {'everything':>12s} {'share':>6s}")
    te, tw = sum(est.values()), sum(whole.values())
    for k in order:
        print(f"{k:24s} {est[k] / samples:12.0f} {100.0 * est[k] / max(te, 1):5.1f}% {whole[k] / samples:12.0f} {100.0 * whole[k] / max(tw, 1):5.1f}%")
    print(f"{'total':24s} {te / samples:12.0f} {'':6s} {tw / samples:12.0f}")
    print("the estimators' instructions by source file, per sample: floating-point arithmetic, all")
    files = sorted({k.split("|")[0] for k in by_file}, key=lambda f: -sum(v for k, v in by_file.items() if k.startswith(f + "|")))
    for f in files:
        fp = by_file.get(f + "|fp arithmetic", 0)
        al = sum(v for k, v in by_file.items() if k.startswith(f + "|"))
        print(f"{f:24s} {fp / samples:8.0f} {al / samples:8.0f}")
    print("the estimators' floating-point arithmetic by mnemonic, per sample:")
    for op, n in est_fp.most_common():
        print(f"{op:16s} {n / samples:8.0f}")
