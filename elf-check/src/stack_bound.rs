//! A static bound on the stack of a linked firmware image ("≤ 16 KB RAM including
//! stacks"), read from its machine code, for the build that cannot be run here: the flight
//! computer's. The QEMU board's stack is *measured* by painting (`firmware/src/board/stack.rs`);
//! the same analysis applied to the QEMU image must bound that measurement from above, which the
//! QEMU replay test checks.
//!
//! ## Method
//! The image is disassembled (`llvm-objdump -d`, as for [`crate::panic_audit`]). For every
//! function a data-flow pass over its control-flow graph tracks the bytes of stack in use at each
//! instruction: `push`/`vpush`/`stmdb sp!`, `sub sp, #n` and pre-indexed stores to `[sp, #-n]!`
//! grow it; `pop`/`vpop`/`ldm sp!`, `add sp, #n` and post-indexed loads from `[sp], #n` shrink
//! it. Where paths join, the larger depth is kept. Any other write to `sp` fails the analysis, so an
//! unknown idiom cannot silently lower the bound. Conditional instructions are taken at their
//! worst (a conditional shrink is ignored). Jump tables (`tbb`/`tbh`) are decoded from the data
//! that follows them; code no path reaches (padding, after calls that never return) is dead.
//!
//! The bound of a function is the larger of its own deepest point and, over its calls
//! (`bl`, branches out of the function, fall-through into the next symbol), the depth at the call
//! plus the callee's bound. An indirect call (`blx rN`, `bx rN`) reaches the *address-taken*
//! functions (whose address, with the Thumb bit, appears as a word in `.rodata`, `.data` or a
//! literal pool of `.text`, or is built by a `movw`/`movt` pair) that the configuration names for
//! its caller, each line with its reason; an indirect call the configuration does not resolve is an
//! error. Recursion, through direct or indirect calls, is an error: no finite bound exists.
//!
//! Calls into the panic machinery ([`crate::panic_audit::is_panic_entry`]) are not followed: a
//! panic ends the program (the panic handler halts it), so the stack it uses cannot corrupt
//! anything that is still needed, and the panic paths left are audited separately.
//!
//! Along the same data flow the interrupt masking is tracked: `cpsid i`/`cpsie i`, `msr primask`,
//! and BASEPRI, which RTIC's `lock` raises to the resource's ceiling (`msr basepri_max` of a
//! constant, converted to a logical priority with the configured priority bits). A restore of a
//! saved value (`mrs` into a register, possibly spilled to the stack) is followed exactly; any
//! other restore counts as no masking at all. Masking a callee leaves behind is taken from its
//! returns; calls to a configured critical section (defmt's logger lock, which keeps its restore
//! value in memory) mask on acquire and restore on release.
//!
//! The whole image's bound nests the handlers as the hardware can (the stack resource policy RTIC
//! relies on): a handler of priority `p` (from the configuration) preempts a point only if the
//! point's effective level — the running handler's priority or the masking, whichever is higher —
//! is below `p`, and each preemption adds the exception frame the core pushes (26 words with the
//! FPU context, plus 4 bytes of alignment: 108 B). Thread mode (`main`: `init` with interrupts
//! masked, then `idle`) is the base. Handlers the configuration does not list (the faults, the
//! default handler) are added on top of the worst nesting, each once.
//!
//! The configuration ([`Config`], `firmware/stack-bound.txt`) carries what the machine code does not
//! say: the handlers' priorities, the targets of indirect calls, and the critical sections.

use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::path::Path;
use std::process::Command;

/// Bytes the Cortex-M4F pushes on exception entry with the FPU context (ARMv7-M ARM B1.5.7:
/// 8 basic words + 18 FP words), plus 4 of alignment padding.
pub const EXCEPTION_FRAME_BYTES: u64 = 26 * 4 + 4;

/// One disassembled instruction (or data word).
#[derive(Debug, Clone)]
struct Insn {
    addr: u64,
    mnemonic: String,
    operands: String,
}

/// One function (symbol) of the disassembly.
#[derive(Debug, Clone)]
struct Function {
    name: String,
    start: u64,
    insns: Vec<Insn>,
}

/// The bound of one entry point, with its deepest call chain.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RootBound {
    /// The entry (vector table slot name and function).
    pub name: String,
    /// The handler's function (short name).
    pub function: String,
    /// Its RTIC logical priority from the configuration (`None`: thread mode, or a handler the
    /// configuration does not list, taken to preempt everything).
    pub priority: Option<u8>,
    /// Its deepest stack alone, bytes, the exception frame included for handlers.
    pub bytes: u64,
    /// The deepest chain: function names with the stack in use on entry to each.
    pub chain: Vec<(String, u64)>,
}

/// An `indirect` line of the configuration: an indirect call in a function whose name contains
/// `caller` may reach every address-taken function whose name contains one of the `callees`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Resolution {
    /// Substring of the calling function.
    pub caller: String,
    /// Substrings of the address-taken functions it may call.
    pub callees: Vec<String>,
    /// Why these are all it can call.
    pub reason: String,
    /// `indirect?`: a call only some images make (one board's logger, say), so not reported stale
    /// where none uses it.
    pub optional: bool,
}

/// The configuration file (`firmware/stack-bound.txt`): one item per line, `#` starts a comment.
///
/// * `prio-bits | N | why`: the NVIC's priority bits (4 on the STM32F4), to read BASEPRI values;
/// * `priority | HANDLER | P | why`: the RTIC logical priority `P` of a vector-table handler
///   (exact function name); handlers not listed are taken to preempt everything, each other too;
///   `priority?` for a handler that only some images have (no error when it is absent);
/// * `indirect | caller | callee, callee | why`: see [`Resolution`]; `indirect?` for a call that
///   only some images make (not reported stale where unused);
/// * `critical-section | ACQUIRE, ACQUIRE | RELEASE | why`: calls to `ACQUIRE` mask interrupts
///   and save the masking where a later call to `RELEASE` restores it (exact function names).
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Config {
    /// NVIC priority bits.
    pub prio_bits: u32,
    /// Handler function → logical priority.
    pub priorities: Vec<(String, u8)>,
    /// Handlers that one board's image has and another's not (`priority?`): no error when absent.
    pub optional: Vec<String>,
    /// Indirect-call resolutions.
    pub indirect: Vec<Resolution>,
    /// Critical sections entered and left by calls: the acquire functions (exact names), and the
    /// release functions that restore the masking the acquire saved (in memory, where the data
    /// flow cannot follow it).
    pub critical_sections: Vec<(Vec<String>, Vec<String>)>,
}

/// Parses the configuration (see [`Config`]).
pub fn parse_config(text: &str) -> Result<Config, String> {
    let mut c = Config {
        prio_bits: 0,
        ..Config::default()
    };
    for (n, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let parts: Vec<&str> = line.split(" | ").map(str::trim).collect();
        let bad = |what: &str| format!("line {}: `{what}` expected", n + 1);
        match parts.as_slice() {
            ["prio-bits", b, why] if !why.is_empty() => {
                c.prio_bits = b
                    .parse()
                    .ok()
                    .filter(|b| (1..=8).contains(b))
                    .ok_or_else(|| bad("prio-bits | 1..8 | why"))?;
            }
            [kind @ ("priority" | "priority?"), h, p, why] if !h.is_empty() && !why.is_empty() => {
                let p = p
                    .parse()
                    .ok()
                    .filter(|p| (1..=254).contains(p))
                    .ok_or_else(|| bad("priority | HANDLER | 1..254 | why"))?;
                c.priorities.push((h.to_string(), p));
                if *kind == "priority?" {
                    c.optional.push(h.to_string());
                }
            }
            ["critical-section", acquire, release, why]
                if !acquire.is_empty() && !release.is_empty() && !why.is_empty() =>
            {
                let names = |s: &str| s.split(", ").map(|n| n.trim().to_string()).collect::<Vec<_>>();
                c.critical_sections.push((names(acquire), names(release)));
            }
            [kind @ ("indirect" | "indirect?"), caller, callees, why]
                if !caller.is_empty() && !callees.is_empty() && !why.is_empty() =>
            {
                c.indirect.push(Resolution {
                    caller: caller.to_string(),
                    callees: callees.split(", ").map(|s| s.trim().to_string()).collect(),
                    reason: why.to_string(),
                    optional: *kind == "indirect?",
                })
            }
            _ => {
                return Err(bad(
                    "prio-bits | N | why`, `priority | HANDLER | P | why` or `indirect | caller | callees | why",
                ))
            }
        }
    }
    if c.prio_bits == 0 {
        return Err("no `prio-bits | N | why` line".into());
    }
    Ok(c)
}

/// The analysis of one image.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct StackBound {
    /// The reset handler first, then every distinct handler.
    pub roots: Vec<RootBound>,
    /// The worst nesting: thread mode, then each preempting handler, with the bytes each adds.
    pub nesting: Vec<(String, u64)>,
    /// The stack bound of the whole image, bytes.
    pub total: u64,
    /// Indirect call sites met (caller) and the functions they may reach.
    pub indirect: Vec<(String, Vec<String>)>,
    /// Resolution lines that no reached indirect call used.
    pub stale: Vec<Resolution>,
    /// Functions whose address is taken.
    pub address_taken: usize,
    /// Static RAM: `.data` + `.bss` + `.uninit` (bytes).
    pub static_ram: u64,
}

impl StackBound {
    /// Static RAM plus the stack bound.
    pub fn ram(&self) -> u64 {
        self.static_ram + self.total
    }

    /// The analysis as text.
    pub fn report(&self) -> String {
        let mut out = format!(
            "stack bound: {} B ({} entry points; {} address-taken functions, {} functions with indirect calls)\n",
            self.total,
            self.roots.len(),
            self.address_taken,
            self.indirect.len()
        );
        let nest: Vec<String> = self.nesting.iter().map(|(n, b)| format!("{n} +{b}")).collect();
        out.push_str(&format!("  worst nesting: {}\n", nest.join(" → ")));
        out.push_str("  each entry point alone (the exception frame included):\n");
        for r in &self.roots {
            let p = r.priority.map_or("-".to_string(), |p| p.to_string());
            out.push_str(&format!("  {:>6} B  priority {p:>2}  {}\n", r.bytes, r.name));
            let chain: Vec<String> = r.chain.iter().map(|(f, at)| format!("{} @{at}", short(f))).collect();
            if chain.len() > 1 {
                out.push_str(&format!("            {}\n", chain.join(" → ")));
            }
        }
        for (caller, callees) in &self.indirect {
            out.push_str(&format!("  indirect call in {caller} → {}\n", callees.join(", ")));
        }
        for r in &self.stale {
            out.push_str(&format!(
                "  stale resolution (no reached indirect call uses it; remove it): {} | {}\n",
                r.caller,
                r.callees.join(", ")
            ));
        }
        out.push_str(&format!(
            "static RAM (.data + .bss + .uninit): {} B; with the stack bound: {} B\n",
            self.static_ram,
            self.ram()
        ));
        out
    }
}

/// A function name without its hash and generic noise, for the report.
fn short(name: &str) -> String {
    let n = match name.rfind("::h") {
        Some(at) if name.len() - at == 19 => &name[..at],
        _ => name,
    };
    n.replace("$LT$", "<")
        .replace("$GT$", ">")
        .replace("$C$", ",")
        .replace("$u20$", " ")
        .replace("$RF$", "&")
        .replace("$u7b$", "{")
        .replace("$u7d$", "}")
        .replace("..", "::")
}

fn parse(dis: &str) -> Vec<Function> {
    let mut out: Vec<Function> = Vec::new();
    for line in dis.lines() {
        let t = line.trim_end();
        if let Some(rest) = t.strip_suffix(">:") {
            if let Some((addr, name)) = rest.split_once(" <") {
                if let Ok(start) = u64::from_str_radix(addr, 16) {
                    out.push(Function {
                        name: name.to_string(),
                        start,
                        insns: Vec::new(),
                    });
                    continue;
                }
            }
        }
        // ` 8000100:      \tpush\t{r7, lr}` (data: ` 80001c8: 38 16 00 20  \t.word\t0x20001638`).
        let Some((addr, rest)) = t.trim_start().split_once(':') else {
            continue;
        };
        let Ok(addr) = u64::from_str_radix(addr, 16) else {
            continue;
        };
        let mut parts = rest.split('\t').skip(1);
        let Some(mnemonic) = parts.next() else {
            continue;
        };
        // Some instructions print their operand after a space, not a tab (`cpsid i`).
        let (mnemonic, operands) = match parts.next() {
            Some(ops) => (mnemonic.trim(), ops),
            None => mnemonic.trim().split_once(' ').unwrap_or((mnemonic.trim(), "")),
        };
        let operands = operands.split(" @").next().unwrap_or("").trim().to_string();
        if let Some(f) = out.last_mut() {
            f.insns.push(Insn {
                addr,
                mnemonic: mnemonic.to_string(),
                operands,
            });
        }
    }
    out
}

const CONDITIONS: [&str; 16] = [
    "eq", "ne", "cs", "hs", "cc", "lo", "mi", "pl", "vs", "vc", "hi", "ls", "ge", "lt", "gt", "le",
];

/// Splits a mnemonic into its base and whether it is conditional: `popeq` → (`pop`, true),
/// `bne.w` → (`b`, true), `bl` → (`bl`, false).
fn split_mnemonic(m: &str) -> (String, bool) {
    let m = m.trim_end_matches(".w").trim_end_matches(".n");
    const EXACT: [&str; 6] = ["bl", "blx", "bx", "b", "cbz", "cbnz"];
    if EXACT.contains(&m) {
        return (m.to_string(), false);
    }
    if let Some(c) = m.strip_prefix('b') {
        if CONDITIONS.contains(&c) {
            return ("b".into(), true);
        }
    }
    // Only the mnemonics the analysis reads take a condition suffix here (`movs` is not `mo` + `vs`).
    const KNOWN: [&str; 29] = [
        "push", "pop", "vpush", "vpop", "add", "sub", "addw", "subw", "ldr", "ldrd", "str", "strd", "ldm", "ldmia",
        "ldmfd", "stmdb", "stmfd", "vstmdb", "vldmia", "vldm", "mov", "movw", "msr", "bx", "bl", "blx", "udf", "tbb",
        "tbh",
    ];
    for c in CONDITIONS {
        if let Some(base) = m.strip_suffix(c) {
            if KNOWN.contains(&base) {
                return (base.to_string(), true);
            }
        }
    }
    (m.to_string(), false)
}

/// Bytes of a register list `{r4, r5, lr}` / `{d8, d9}` / `{s16-s31}`.
fn list_bytes(ops: &str) -> Result<(u64, bool), String> {
    let inner = ops
        .split_once('{')
        .and_then(|(_, r)| r.split_once('}'))
        .map(|(l, _)| l)
        .ok_or_else(|| format!("no register list in `{ops}`"))?;
    let mut bytes = 0;
    let mut pc = false;
    for reg in inner.split(',').map(str::trim) {
        let (first, last) = reg.split_once('-').unwrap_or((reg, reg));
        let width = match first.as_bytes().first() {
            Some(b'd') => 8,
            _ => 4,
        };
        let n = |r: &str| r.trim_start_matches(['r', 'd', 's']).parse::<u64>().ok();
        let count = match (n(first), n(last)) {
            (Some(a), Some(b)) if b >= a && first != last => b - a + 1,
            _ => 1,
        };
        pc |= reg == "pc";
        bytes += width * count;
    }
    Ok((bytes, pc))
}

fn immediate(s: &str) -> Option<i64> {
    let s = s.trim().trim_start_matches('#');
    let (neg, s) = match s.strip_prefix('-') {
        Some(r) => (true, r),
        None => (false, s),
    };
    let v = match s.strip_prefix("0x") {
        Some(h) => i64::from_str_radix(h, 16).ok()?,
        None => s.parse().ok()?,
    };
    Some(if neg { -v } else { v })
}

/// What an instruction does to the stack: bytes it grows (negative: shrinks), and whether it
/// returns (pops `pc`).
fn stack_effect(base: &str, ops: &str) -> Result<(i64, bool), String> {
    match base {
        "push" | "vpush" => return Ok((list_bytes(ops)?.0 as i64, false)),
        "pop" | "vpop" => {
            let (b, pc) = list_bytes(ops)?;
            return Ok((-(b as i64), pc));
        }
        _ => {}
    }
    let ops_t = ops.replace(' ', "");
    if matches!(base, "stmdb" | "stmfd" | "vstmdb") && ops_t.starts_with("sp!,") {
        return Ok((list_bytes(ops)?.0 as i64, false));
    }
    if matches!(base, "ldm" | "ldmia" | "ldmfd" | "vldmia" | "vldm") && ops_t.starts_with("sp!,") {
        let (b, pc) = list_bytes(ops)?;
        return Ok((-(b as i64), pc));
    }
    if matches!(base, "sub" | "subw" | "add" | "addw") {
        let imm = ops_t
            .strip_prefix("sp,sp,")
            .or_else(|| ops_t.strip_prefix("sp,"))
            .and_then(immediate);
        if let Some(imm) = imm {
            return Ok((if base.starts_with("sub") { imm } else { -imm }, false));
        }
    }
    if ops_t.contains("[sp,#-") && ops_t.ends_with("]!") {
        if let Some(n) = ops_t
            .rsplit_once("[sp,#")
            .and_then(|(_, r)| immediate(r.trim_end_matches("]!")))
        {
            return Ok((-n, false));
        }
    }
    if ops_t.contains("[sp],#") {
        if let Some(n) = ops_t.rsplit_once("[sp],#").and_then(|(_, r)| immediate(r)) {
            return Ok((-n, ops_t.starts_with("pc,")));
        }
    }
    // A load or store multiple with `sp` as its base and no writeback (`ldm sp, {r0, r2}`) reads it;
    // with writeback, only the forms matched above are understood.
    let multiple = ["ldm", "stm", "vldm", "vstm"].iter().any(|m| base.starts_with(m));
    if multiple && ops_t.starts_with("sp!") {
        return Err(format!("unrecognised write to sp: `{base} {ops}`"));
    }
    if multiple && ops_t.contains("pc}") {
        return Err(format!("unrecognised write to pc: `{base} {ops}`"));
    }
    if base == "msr" && ["msp,", "psp,", "control,"].iter().any(|r| ops_t.starts_with(r)) {
        return Err(format!("a write to the stack pointer or CONTROL: `{base} {ops}`"));
    }
    let writes_sp = ops_t.starts_with("sp,")
        && !multiple
        && !matches!(
            base,
            "cmp" | "cmn" | "tst" | "teq" | "str" | "strd" | "strb" | "strh" | "vstr"
        );
    if writes_sp || ops_t.contains("[sp") && ops_t.ends_with('!') {
        return Err(format!("unrecognised write to sp: `{base} {ops}`"));
    }
    Ok((0, false))
}

/// The branch target named by objdump (`0x8000300 <sym+0x4>`).
fn target(ops: &str) -> Option<u64> {
    let t = ops.split_whitespace().find(|w| w.starts_with("0x"))?;
    u64::from_str_radix(t.trim_start_matches("0x").trim_end_matches(','), 16).ok()
}

/// The entries of the jump table after the `tbb`/`tbh` at `f.insns[at]`: target addresses. The
/// data after the instruction may hold more than the table (its padding, a constant island the
/// compiler placed behind it), and the index bound is not always beside it. The table ends before
/// the first entry whose target lies inside the entries read so far: a case's code follows the
/// table, so no real entry points into it (a zero entry, padding, among them), and the table is
/// contiguous. Every entry before that must name an instruction.
fn table_targets(f: &Function, at: usize, index: &HashMap<u64, usize>) -> Result<Vec<u64>, String> {
    let insn = &f.insns[at];
    let table = insn.addr + 4;
    let bytes = table_bytes(&f.insns[at + 1..]);
    let (base, _) = split_mnemonic(&insn.mnemonic);
    let width: u64 = if base == "tbb" { 1 } else { 2 };
    let all: Vec<u64> = if base == "tbb" {
        bytes.iter().map(|&b| u64::from(b)).collect()
    } else {
        bytes
            .chunks_exact(2)
            .map(|c| u64::from(u16::from_le_bytes([c[0], c[1]])))
            .collect()
    };
    let end = all
        .iter()
        .enumerate()
        .position(|(i, &e)| 2 * e < (i as u64 + 1) * width)
        .unwrap_or(all.len());
    let mut entries: Vec<u64> = all[..end].to_vec();
    while entries.last() == Some(&0) && entries.len() > 1 {
        entries.pop();
    }
    let targets: Vec<u64> = entries.iter().map(|e| table + 2 * e).collect();
    match targets.iter().find(|t| !index.contains_key(t)) {
        Some(t) => Err(format!(
            "{} at {:#x}: a jump-table entry ({t:#x}) that is not an instruction",
            f.name, insn.addr
        )),
        None if targets.is_empty() => Err(format!("{} at {:#x}: a jump table without entries", f.name, insn.addr)),
        None => Ok(targets),
    }
}

/// The bytes of the data directives (`.word`, `.short`, `.byte`) at the start of `insns`.
fn table_bytes(insns: &[Insn]) -> Vec<u8> {
    let mut out = Vec::new();
    for i in insns {
        let width = match i.mnemonic.as_str() {
            ".word" => 4,
            ".short" => 2,
            ".byte" => 1,
            _ => break,
        };
        let Some(v) = immediate(&i.operands) else { break };
        out.extend_from_slice(&(v as u32).to_le_bytes()[..width]);
    }
    out
}

/// The masking level meaning "every maskable interrupt is masked" (`cpsid i`, PRIMASK set).
pub const MASK_ALL: u8 = u8::MAX;

/// Per function: the deepest point at each interrupt-masking level it sets itself (RTIC logical
/// priority masked by BASEPRI, [`MASK_ALL`] under PRIMASK, 0 for none), and its outgoing calls
/// with the depth and level at each.
#[derive(Debug, Default, Clone)]
struct Frame {
    own: BTreeMap<Level, u64>,
    calls: Vec<(u64, Level, Callee)>,
    /// The masking at its returns (joined), `None` if it never returns.
    exit: Option<State>,
}

/// A masking level and whether it is absolute (set by a `cpsie`, a restore, or after a call) or
/// relative to the caller's level at the call (the caller's masking still holds, raised by the
/// function's own `cpsid` or BASEPRI writes).
type Level = (u8, bool);

/// The level of a callee's point `l` when called at level `at`.
fn compose(at: Level, l: Level) -> Level {
    if l.1 {
        l
    } else {
        (l.0.max(at.0), at.1)
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Callee {
    Direct(u64),
    Indirect,
}

/// Index of the function containing `addr`.
fn containing(funcs: &[Function], addr: u64) -> Option<usize> {
    let i = funcs.partition_point(|f| f.start <= addr).checked_sub(1)?;
    // Past the last instruction of the last symbol is outside the code.
    let end = funcs.get(i + 1).map_or_else(
        || funcs[i].insns.last().map_or(funcs[i].start, |l| l.addr + 4),
        |g| g.start,
    );
    (addr < end).then_some(i)
}

/// A saved masking: BASEPRI level, PRIMASK, absolute.
type Mask = (u8, bool, bool);

/// The worst nesting above a level: bytes, and (handler, bytes it adds) in order.
type Nesting = (u64, Vec<(String, u64)>);

/// The data-flow state at an instruction: stack bytes in use, the BASEPRI level, PRIMASK, and
/// whether the masking is absolute (see [`Level`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct State {
    depth: i64,
    basepri: u8,
    primask: bool,
    absolute: bool,
    /// Registers r0–r12 holding a masking saved by `mrs rN, primask|basepri` (basepri, primask,
    /// absolute at the save), so that the restore `msr …, rN` is exact.
    saved: [Option<(u8, bool, bool)>; 13],
    /// The masking before the last call to a critical section's acquire function (see
    /// [`Config::critical_sections`]), which its release restores.
    section: Option<(u8, bool, bool)>,
    /// Saved maskings spilled to the stack (`str rN, [sp, #off]`), by their distance from the
    /// function's entry stack pointer, so that a reload before the restore stays exact.
    slots: [Option<(i64, Mask)>; 4],
}

/// Mnemonics that write no general-purpose register (stores, compares, branches, barriers).
const READS_ONLY: [&str; 24] = [
    "str", "strb", "strh", "strd", "stm", "stmia", "stmdb", "push", "vpush", "vstr", "vstmia", "vstmdb", "cmp", "cmn",
    "tst", "teq", "b", "cbz", "cbnz", "msr", "vcmp", "vcmpe", "nop", "isb",
];

/// Register numbers named in an operand list (`r4`, `r12`).
fn registers(ops: &str) -> impl Iterator<Item = usize> + '_ {
    ops.split(|c: char| !c.is_ascii_alphanumeric())
        .filter_map(|w| w.strip_prefix('r')?.parse::<usize>().ok())
        .filter(|&n| n < 13)
}

impl State {
    fn level(&self) -> Level {
        (if self.primask { MASK_ALL } else { self.basepri }, self.absolute)
    }

    /// The join of two paths: the deeper stack, the weaker masking (both conservative; a
    /// relative level read as absolute is never higher than the true one).
    fn join(self, o: State) -> State {
        State {
            depth: self.depth.max(o.depth),
            basepri: self.basepri.min(o.basepri),
            primask: self.primask && o.primask,
            absolute: self.absolute || o.absolute,
            saved: core::array::from_fn(|k| {
                if self.saved[k] == o.saved[k] {
                    self.saved[k]
                } else {
                    None
                }
            }),
            section: if self.section == o.section { self.section } else { None },
            slots: if self.slots == o.slots { self.slots } else { [None; 4] },
        }
    }

    /// Masking dropped to none, absolutely (a restore of an unknown value, or a callee that may
    /// have changed it).
    fn unmasked(self) -> State {
        State {
            basepri: 0,
            primask: false,
            absolute: true,
            ..self
        }
    }
}

/// The constant last moved into `reg` within the few instructions before `at` (`movs r0, #0xe0`
/// before `msr basepri_max, r0`), if any.
fn constant_in(insns: &[Insn], at: usize, targets: &BTreeSet<u64>, reg: &str) -> Option<i64> {
    if targets.contains(&insns.get(at)?.addr) {
        return None;
    }
    for i in insns[..at].iter().rev().take(8) {
        let (b, _) = split_mnemonic(&i.mnemonic);
        // A call, a load multiple or a pop may write the register without naming it first; a
        // branch target joins paths on which it may hold something else.
        if matches!(
            b.as_str(),
            "bl" | "blx" | "pop" | "ldm" | "ldmia" | "b" | "cbz" | "cbnz" | "tbb" | "tbh"
        ) {
            return None;
        }
        let ops = i.operands.replace(' ', "");
        let Some(rest) = ops.strip_prefix(reg).and_then(|r| r.strip_prefix(',')) else {
            continue;
        };
        let (base, cond) = split_mnemonic(&i.mnemonic);
        return match base.as_str() {
            "mov" | "movs" | "movw" if !cond && !targets.contains(&i.addr) => immediate(rest),
            _ => None,
        };
    }
    None
}

impl Graph<'_> {
    /// The masking after an indirect call in `fi` returns: the join over its resolved callees.
    fn after_indirect(&mut self, fi: usize, after: State) -> Result<State, String> {
        let mut out: Option<State> = None;
        for g in self.indirect_callees(fi)? {
            let s = self.after_call(Some(g), after)?;
            out = Some(out.map_or(s, |o| o.join(s)));
        }
        Ok(out.map_or(after.unmasked(), |s| State {
            depth: after.depth,
            ..s
        }))
    }

    /// The masking after a call returns: the callee's at its returns (an RTIC lock's
    /// `critical_section::acquire` returns with interrupts masked, `init` enables them); after an
    /// indirect call, none (absolutely).
    fn after_call(&mut self, g: Option<usize>, after: State) -> Result<State, String> {
        let Some(g) = g else { return Ok(after.unmasked()) };
        if self.is_panic(g) {
            return Ok(after);
        }
        let name = short(&self.funcs[g].name);
        let before = (after.basepri, after.primask, after.absolute);
        if self
            .config
            .critical_sections
            .iter()
            .any(|(_, release)| release.contains(&name))
        {
            // The release restores what the acquire saved.
            return Ok(match after.section {
                // Only PRIMASK is restored (defmt's lock); BASEPRI is what it is now.
                Some((_, p, abs)) => State {
                    primask: p,
                    absolute: after.absolute || abs,
                    section: None,
                    ..after
                },
                None => after.unmasked(),
            });
        }
        if self
            .config
            .critical_sections
            .iter()
            .any(|(acquire, _)| acquire.contains(&name))
        {
            // The acquire returns with interrupts masked, the caller's masking saved.
            return Ok(State {
                primask: true,
                section: Some(before),
                ..after
            });
        }
        let out = match self.frame(g)?.exit {
            None => after,
            Some(e) if e.absolute => State {
                depth: after.depth,
                saved: after.saved,
                section: after.section,
                slots: after.slots,
                ..e
            },
            Some(e) => State {
                basepri: after.basepri.max(e.basepri),
                primask: after.primask || e.primask,
                ..after
            },
        };
        Ok(out)
    }

    /// The frame of function `fi` (memoised): the data flow over its instructions. The masking after
    /// a direct call is the callee's at its returns (its own frame, computed first).
    fn frame(&mut self, fi: usize) -> Result<Frame, String> {
        if let Some(f) = &self.frames[fi] {
            return Ok(f.clone());
        }
        if self.frame_busy[fi] {
            return Err(format!(
                "recursion through {}: no finite stack bound",
                short(&self.funcs[fi].name)
            ));
        }
        self.frame_busy[fi] = true;
        let mut w = FrameWalk::new(self.funcs, fi)?;
        while let Some((k, st)) = w.seeds.pop() {
            if let Some(st) = w.enter(k, st)? {
                self.frame_step(&mut w, k, st)?;
            }
        }
        let out = Frame {
            own: w.own,
            calls: w.calls.into_iter().collect(),
            exit: w.exit,
        };
        self.frame_busy[fi] = false;
        self.frames[fi] = Some(out.clone());
        Ok(out)
    }

    /// One instruction of the walk, entered at state `st`: its effect on the stack and the
    /// masking, then where control goes (the next instruction, branch targets, calls, returns).
    fn frame_step(&mut self, w: &mut FrameWalk, k: usize, st: State) -> Result<(), String> {
        let (f, insn) = (w.f, w.code[k].1);
        let (base, cond) = split_mnemonic(&insn.mnemonic);
        let (grow, ret) =
            stack_effect(&base, &insn.operands).map_err(|e| format!("{} at {:#x}: {e}", f.name, insn.addr))?;
        let mut after = st;
        after.depth = if cond && grow < 0 { st.depth } else { st.depth + grow };
        let ops = insn.operands.replace(' ', "");
        let write = MaskingWrite {
            insns: &f.insns,
            at: w.code[k].0,
            targets: &w.targets,
            prio_bits: self.prio_bits,
        };
        apply_masking(&write, &base, &ops, st, &mut after);
        track_saved(&base, &ops, &insn.operands, st, &mut after);
        if cond {
            after = State {
                depth: after.depth,
                ..after.join(st)
            };
        }
        for s in [st, after] {
            let e = w.own.entry(s.level()).or_default();
            *e = (*e).max(s.depth.max(0) as u64);
        }
        if ret || (base == "bx" && insn.operands.trim() == "lr") {
            w.join_exit(after);
        }
        let op = Op {
            base: &base,
            cond,
            ret,
            ops: &ops,
        };
        let fall = self.transfer(w, k, &op, &mut after)?;
        if fall {
            let next = k + 1;
            if next < w.code.len() {
                w.seeds.push((next, after));
            } else if let Some(g) = self.funcs.get(w.fi + 1) {
                // Falls off the end into the next symbol: a tail call to it.
                record(&mut w.calls, Callee::Direct(g.start), after);
                let e = self.after_call(Some(w.fi + 1), after)?;
                w.join_exit(e);
            }
        }
        Ok(())
    }

    /// Where control goes after instruction `k` (decoded as `op`) leaves the state `after`:
    /// calls (which change `after` to the state when they return), branches and jump tables
    /// (seeding their targets), tail calls and indirect jumps (joined into the exit). Returns
    /// whether control may fall through to the next instruction.
    fn transfer(&mut self, w: &mut FrameWalk, k: usize, op: &Op, after: &mut State) -> Result<bool, String> {
        let (f, insn) = (w.f, w.code[k].1);
        let cond = op.cond;
        let mut fall = !op.ret || cond;
        match op.base {
            "bl" | "blx" => {
                if !self.call_transfer(w, k, op, after)? {
                    fall = cond;
                }
            }
            "bx" => {
                if insn.operands.trim() != "lr" {
                    record(&mut w.calls, Callee::Indirect, *after);
                    let e = self.after_indirect(w.fi, *after)?;
                    w.join_exit(e);
                }
                fall = cond;
            }
            "b" | "cbz" | "cbnz" => {
                let t = target(&insn.operands)
                    .ok_or_else(|| format!("{} at {:#x}: branch without a target", f.name, insn.addr))?;
                match w.index.get(&t) {
                    Some(&tk) if w.inside(t) => w.seeds.push((tk, *after)),
                    _ => {
                        // A tail call: its returns are this function's.
                        record(&mut w.calls, Callee::Direct(t), *after);
                        let g = containing(self.funcs, t)
                            .ok_or_else(|| format!("call to {t:#x} outside every function"))?;
                        let e = self.after_call(Some(g), *after)?;
                        w.join_exit(e);
                    }
                }
                if op.base == "b" && !cond {
                    fall = false;
                }
            }
            "tbb" | "tbh" => {
                // The table follows the instruction (objdump shows it as data).
                for t in table_targets(f, w.code[k].0, &w.index)? {
                    if let Some(&tk) = w.index.get(&t) {
                        w.seeds.push((tk, *after));
                    }
                }
                fall = cond;
            }
            "udf" | "trap" => fall = cond,
            _ => {
                if !op.ret && op.ops.starts_with("pc,") && op.base != "str" {
                    if op.base == "ldr" || op.base == "mov" {
                        record(&mut w.calls, Callee::Indirect, *after);
                        let e = self.after_indirect(w.fi, *after)?;
                        w.join_exit(e);
                        fall = cond;
                    } else {
                        return Err(format!(
                            "{} at {:#x}: unrecognised write to pc: `{} {}`",
                            f.name, insn.addr, insn.mnemonic, insn.operands
                        ));
                    }
                }
            }
        }
        Ok(fall)
    }

    /// A `bl`/`blx` at instruction `k`: `after` becomes the state when it returns (the callee's
    /// masking at its returns, an RTIC lock's `critical_section::acquire` returning with
    /// interrupts masked, `init` enabling them; after an indirect call, none, absolutely).
    /// Returns whether the call returns (a direct call of a function that never does ends the
    /// path).
    fn call_transfer(&mut self, w: &mut FrameWalk, k: usize, op: &Op, after: &mut State) -> Result<bool, String> {
        let (f, insn) = (w.f, w.code[k].1);
        match target(&insn.operands) {
            Some(t) => {
                let returns;
                (*after, returns) = self.direct_call(t, *after, op.cond, &mut w.calls)?;
                Ok(returns)
            }
            None if op.base == "blx" => {
                record(&mut w.calls, Callee::Indirect, *after);
                let pre = *after;
                *after = self.after_indirect(w.fi, *after)?;
                if op.cond {
                    *after = State {
                        depth: after.depth,
                        ..after.join(pre)
                    };
                }
                Ok(true)
            }
            None => Err(format!("{} at {:#x}: bl without a target", f.name, insn.addr)),
        }
    }

    /// A direct call of `t` from the state `after` (`cond`: a conditional call), recorded in
    /// `calls`; the state when it returns (a conditional call's joined with the state before it,
    /// the call not taken), and whether it returns at all.
    fn direct_call(
        &mut self,
        t: u64,
        after: State,
        cond: bool,
        calls: &mut BTreeSet<(u64, Level, Callee)>,
    ) -> Result<(State, bool), String> {
        let g = containing(self.funcs, t).ok_or_else(|| format!("call to {t:#x} outside every function"))?;
        // A critical section's release runs at the masking it restores (that of the matching
        // acquire's caller), at most: its points count at that level.
        let mut at = after;
        if self.is_release(g) {
            // The weaker of the masking now and the one it restores.
            let (b, p, abs) = after.section.unwrap_or((0, false, true));
            at.basepri = at.basepri.min(b);
            at.primask &= p;
            at.absolute |= abs;
        }
        record(calls, Callee::Direct(t), at);
        let mut out = self.after_call(Some(g), after)?;
        if cond {
            // Not taken: the masking before the call.
            out = State {
                depth: out.depth,
                ..out.join(after)
            };
        }
        // A callee that never returns (`halt`, the panic machinery) ends the path.
        let returns = !(self.is_panic(g) || self.frame(g)?.exit.is_none());
        Ok((out, returns))
    }
}

/// An instruction as the walk reads it: the base mnemonic, whether it is conditional, whether it
/// returns, and its operands without spaces.
struct Op<'s> {
    base: &'s str,
    cond: bool,
    ret: bool,
    ops: &'s str,
}

/// The data flow over one function's instructions, in progress: the function and its code (the
/// instructions that are not data, with their index among all), their positions by address, the
/// function's end and branch targets; the state entering each instruction, the deepest point at
/// each level, the calls, the joined state at the returns and the work list.
struct FrameWalk<'f> {
    fi: usize,
    f: &'f Function,
    code: Vec<(usize, &'f Insn)>,
    index: HashMap<u64, usize>,
    end: u64,
    targets: BTreeSet<u64>,
    state_in: Vec<Option<State>>,
    own: BTreeMap<Level, u64>,
    calls: BTreeSet<(u64, Level, Callee)>,
    exit: Option<State>,
    seeds: Vec<(usize, State)>,
}

impl<'f> FrameWalk<'f> {
    /// The walk of `funcs[fi]`, seeded with its entry (no stack, no masking of its own).
    fn new(funcs: &'f [Function], fi: usize) -> Result<Self, String> {
        let f = &funcs[fi];
        let code: Vec<(usize, &Insn)> = f
            .insns
            .iter()
            .enumerate()
            .filter(|(_, i)| !i.mnemonic.starts_with('.'))
            .collect();
        let index: HashMap<u64, usize> = code.iter().enumerate().map(|(k, (_, i))| (i.addr, k)).collect();
        let end = funcs.get(fi + 1).map_or(u64::MAX, |g| g.start);
        let targets = branch_targets(f, &code, &index, end)?;
        let entry = State {
            depth: 0,
            basepri: 0,
            primask: false,
            absolute: false,
            saved: [None; 13],
            section: None,
            slots: [None; 4],
        };
        Ok(Self {
            fi,
            f,
            state_in: vec![None; code.len()],
            code,
            index,
            end,
            targets,
            own: BTreeMap::new(),
            calls: BTreeSet::new(),
            exit: None,
            seeds: vec![(0usize, entry)],
        })
    }

    fn inside(&self, a: u64) -> bool {
        a >= self.f.start && a < self.end
    }

    /// Instruction `k` entered at `st`: the state joined with the one it had, or `None` when
    /// there is nothing new to walk (past the end, or no change).
    fn enter(&mut self, k: usize, st: State) -> Result<Option<State>, String> {
        if k >= self.code.len() {
            return Ok(None);
        }
        let st = match self.state_in[k] {
            Some(old) if old.join(st) == old => return Ok(None),
            Some(old) => old.join(st),
            None => st,
        };
        if st.depth > 1 << 24 {
            return Err(format!("{}: the stack grows without bound in a loop", self.f.name));
        }
        self.state_in[k] = Some(st);
        Ok(Some(st))
    }

    /// A state at a return of the function, joined into the exit.
    fn join_exit(&mut self, e: State) {
        self.exit = Some(self.exit.map_or(e, |x| x.join(e)));
    }
}

/// A call to `c` made at the state `at`: its depth and masking level.
fn record(calls: &mut BTreeSet<(u64, Level, Callee)>, c: Callee, at: State) {
    calls.insert((at.depth.max(0) as u64, at.level(), c));
}

/// Every address a branch or a jump table of function `f` reaches (a branch's only inside it,
/// `end` being the next function's start), for `constant_in`.
fn branch_targets(
    f: &Function,
    code: &[(usize, &Insn)],
    index: &HashMap<u64, usize>,
    end: u64,
) -> Result<BTreeSet<u64>, String> {
    let inside = |a: u64| a >= f.start && a < end;
    let mut targets: BTreeSet<u64> = BTreeSet::new();
    for &(at, i) in code {
        let (b, _) = split_mnemonic(&i.mnemonic);
        match b.as_str() {
            "b" | "cbz" | "cbnz" => targets.extend(target(&i.operands).filter(|&t| inside(t))),
            "tbb" | "tbh" => targets.extend(table_targets(f, at, index)?),
            _ => {}
        }
    }
    Ok(targets)
}

/// Where an instruction that may write the masking is, for finding the constant it writes: the
/// function's instructions, its index among them, the function's branch targets
/// ([`branch_targets`]), and the implemented priority bits.
struct MaskingWrite<'a> {
    insns: &'a [Insn],
    at: usize,
    targets: &'a BTreeSet<u64>,
    prio_bits: u32,
}

impl MaskingWrite<'_> {
    /// The constant register `reg` holds at the instruction, if visible.
    fn constant(&self, reg: &str) -> Option<i64> {
        constant_in(self.insns, self.at, self.targets, reg)
    }

    /// BASEPRI hardware value → RTIC logical priority masked (`cortex_logical2hw` inverted).
    fn logical(&self, hw: i64) -> u8 {
        let hw = (hw & 0xff) >> (8 - self.prio_bits);
        if hw == 0 {
            0
        } else {
            ((1i64 << self.prio_bits) - hw).clamp(0, 254) as u8
        }
    }
}

/// Interrupt masking after the instruction `base ops` (operands without spaces), from the state
/// `st` before it. A value that is not a visible constant (a restore of a saved BASEPRI or
/// PRIMASK) is taken as no masking: more preemption, a larger bound.
fn apply_masking(w: &MaskingWrite, base: &str, ops: &str, st: State, after: &mut State) {
    let saved_in = |o: &str, prefix: &str| -> Option<(u8, bool, bool)> {
        let n: usize = o.get(prefix.len()..)?.strip_prefix('r')?.parse().ok()?;
        st.saved.get(n).copied().flatten()
    };
    match (base, ops) {
        ("cpsid", "i") => after.primask = true,
        ("cpsie", "i") => {
            after.primask = false;
            after.absolute = true;
        }
        ("msr", o) if o.starts_with("primask,") => {
            if let Some((_, p, abs)) = saved_in(o, "primask,") {
                after.primask = p;
                after.absolute |= abs;
            } else {
                match w.constant(&o["primask,".len()..]) {
                    Some(v) if v & 1 == 1 => after.primask = true,
                    _ => {
                        after.primask = false;
                        after.absolute = true;
                    }
                }
            }
        }
        ("msr", o) if o.starts_with("basepri_max,") => {
            // Only raises; an unknown value raises by an unknown amount: ignored.
            if let Some(v) = w.constant(&o["basepri_max,".len()..]) {
                after.basepri = after.basepri.max(w.logical(v));
            }
        }
        ("msr", o) if o.starts_with("basepri,") => {
            if let Some((b, _, abs)) = saved_in(o, "basepri,") {
                after.basepri = b;
                after.absolute |= abs;
            } else {
                after.basepri = w.constant(&o["basepri,".len()..]).map_or(0, |v| w.logical(v));
                after.absolute = true;
            }
        }
        _ => {}
    }
}

/// The saved maskings after the instruction `base ops` (operands without spaces; `operands` as
/// written), from the state `st` before it: registers it writes lose what they held, a saved
/// masking follows a spill to or a reload from a stack slot, and `mrs` saves one.
fn track_saved(base: &str, ops: &str, operands: &str, st: State, after: &mut State) {
    if matches!(base, "bl" | "blx") {
        for r in [0, 1, 2, 3, 12] {
            after.saved[r] = None;
        }
    } else if !READS_ONLY.contains(&base) || ops.contains('!') || ops.contains("],#") {
        // (A store with writeback or post-indexing writes its base register.)
        for r in registers(operands) {
            after.saved[r] = None;
        }
    }
    if matches!(base, "str" | "ldr") {
        spill_or_reload(base, ops, st, after);
    }
    if base == "mrs" {
        if let Some(r) = registers(operands).next() {
            if ops.ends_with(",primask") || ops.ends_with(",basepri") {
                after.saved[r] = Some((st.basepri, st.primask, st.absolute));
            }
        }
    }
}

/// A saved masking spilled to (`str`), or reloaded from (`ldr`), a stack slot.
fn spill_or_reload(base: &str, ops: &str, st: State, after: &mut State) {
    let sp_slot = |ops: &str| -> Option<(usize, i64)> {
        let (reg, rest) = ops.split_once(',')?;
        let r: usize = reg.strip_prefix('r')?.parse().ok()?;
        let off = match rest {
            "[sp]" => 0,
            _ => immediate(rest.strip_prefix("[sp,#")?.strip_suffix(']')?)?,
        };
        Some((r, st.depth - off))
    };
    let Some((r, pos)) = sp_slot(ops) else { return };
    if base == "str" {
        for slot in after.slots.iter_mut() {
            if slot.is_some_and(|(p, _)| p == pos) {
                *slot = None;
            }
        }
        if let Some(m) = st.saved.get(r).copied().flatten() {
            if let Some(free) = after.slots.iter_mut().find(|s| s.is_none()) {
                *free = Some((pos, m));
            }
        }
    } else if r < 13 {
        after.saved[r] = st.slots.iter().flatten().find(|(p, _)| *p == pos).map(|(_, m)| *m);
    }
}

/// The bound of a function: the deepest point at each masking level (its own and its callees'),
/// the deepest point overall and the callee on the path to it.
#[derive(Debug, Clone, Default)]
struct Profile {
    by_level: BTreeMap<Level, u64>,
    max: u64,
    via: Option<usize>,
}

struct Graph<'a> {
    funcs: &'a [Function],
    prio_bits: u32,
    frames: Vec<Option<Frame>>,
    frame_busy: Vec<bool>,
    taken: Vec<usize>,
    config: &'a Config,
    used: Vec<bool>,
    memo: Vec<Option<Profile>>,
    busy: Vec<bool>,
    /// Indirect call sites met: caller and the callees the resolution gave.
    sites: BTreeMap<usize, Vec<usize>>,
}

impl Graph<'_> {
    fn is_panic(&self, fi: usize) -> bool {
        let name = &self.funcs[fi].name;
        let name = match name.rfind("::h") {
            Some(at) if name.len() - at == 19 => &name[..at],
            _ => name.as_str(),
        };
        crate::panic_audit::is_panic_entry(name)
    }

    /// Whether `fi` is a critical section's release function (configuration).
    fn is_release(&self, fi: usize) -> bool {
        let name = short(&self.funcs[fi].name);
        self.config.critical_sections.iter().any(|(_, r)| r.contains(&name))
    }

    fn open_calls(&self) -> String {
        (0..self.funcs.len())
            .filter(|&g| self.busy[g])
            .map(|g| short(&self.funcs[g].name))
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// The profile of function `fi`.
    fn bound(&mut self, fi: usize) -> Result<Profile, String> {
        if let Some(b) = &self.memo[fi] {
            return Ok(b.clone());
        }
        if self.busy[fi] {
            return Err(format!(
                "recursion through {} (open calls: {}): no finite stack bound",
                short(&self.funcs[fi].name),
                self.open_calls()
            ));
        }
        self.busy[fi] = true;
        let f = self.frame(fi)?;
        let mut p = Profile {
            max: f.own.values().copied().max().unwrap_or(0),
            by_level: f.own,
            via: None,
        };
        for (at, level, c) in f.calls {
            let callees = match c {
                Callee::Direct(t) => match containing(self.funcs, t) {
                    Some(g) if self.is_panic(g) => continue,
                    Some(g) => vec![g],
                    None => return Err(format!("call to {t:#x} outside every function")),
                },
                Callee::Indirect => self.indirect_callees(fi)?,
            };
            for g in callees {
                let q = self.bound(g)?;
                let release = self.is_release(g);
                for (&l, &d) in &q.by_level {
                    // A release's restore (from memory: absolute in its own analysis) returns to
                    // the level it was called at (see `frame`).
                    let l = if release { (l.0, false) } else { l };
                    let e = p.by_level.entry(compose(level, l)).or_default();
                    *e = (*e).max(at + d);
                }
                if at + q.max > p.max || (p.via.is_none() && at + q.max == p.max && q.max > 0) {
                    p.max = at + q.max;
                    p.via = Some(g);
                }
            }
        }
        self.busy[fi] = false;
        self.memo[fi] = Some(p.clone());
        Ok(p)
    }

    /// The callees of an indirect call in `fi`: the address-taken functions the configuration
    /// names for it.
    fn indirect_callees(&mut self, fi: usize) -> Result<Vec<usize>, String> {
        if let Some(c) = self.sites.get(&fi) {
            return Ok(c.clone());
        }
        let caller = short(&self.funcs[fi].name);
        let mut callees = BTreeSet::new();
        let mut covered = false;
        for (k, r) in self.config.indirect.iter().enumerate() {
            if !caller.contains(&r.caller) {
                continue;
            }
            covered = true;
            self.used[k] = true;
            for want in &r.callees {
                let found: Vec<usize> = self
                    .taken
                    .iter()
                    .copied()
                    .filter(|&g| short(&self.funcs[g].name).contains(want.as_str()))
                    .collect();
                if found.is_empty() {
                    return Err(format!(
                        "indirect-call resolution `{} | {}`: no address-taken function matches `{want}`",
                        r.caller,
                        r.callees.join(", ")
                    ));
                }
                callees.extend(found);
            }
        }
        if !covered {
            return Err(format!(
                "an indirect call in {caller} that the configuration does not resolve (add a line \
                 `indirect | caller | callees | why`; address-taken functions: {})",
                self.taken
                    .iter()
                    .map(|&g| short(&self.funcs[g].name))
                    .collect::<Vec<_>>()
                    .join(", ")
            ));
        }
        let callees: Vec<usize> = callees.into_iter().collect();
        self.sites.insert(fi, callees.clone());
        Ok(callees)
    }

    fn chain(&mut self, mut fi: usize) -> Result<Vec<(String, u64)>, String> {
        let mut out = Vec::new();
        let mut at = 0;
        for _ in 0..64 {
            out.push((self.funcs[fi].name.clone(), at));
            let p = self.bound(fi)?;
            let Some(g) = p.via else { break };
            at += p.max - self.bound(g)?.max;
            fi = g;
        }
        Ok(out)
    }
}

/// Little-endian words of a section hex dump (`llvm-objdump -s`), by address.
fn dump_words(dump: &str) -> Vec<(u64, u32)> {
    let mut bytes: BTreeMap<u64, u8> = BTreeMap::new();
    for line in dump.lines() {
        let mut it = line.split_whitespace();
        let Some(addr) = it.next().and_then(|a| u64::from_str_radix(a, 16).ok()) else {
            continue;
        };
        let mut a = addr;
        for group in it.take(4) {
            if group.len() % 2 != 0 || !group.bytes().all(|b| b.is_ascii_hexdigit()) {
                break;
            }
            for k in (0..group.len()).step_by(2) {
                if let Ok(b) = u8::from_str_radix(&group[k..k + 2], 16) {
                    bytes.insert(a, b);
                }
                a += 1;
            }
        }
    }
    bytes
        .keys()
        .filter(|a| *a % 4 == 0)
        .filter_map(|&a| {
            let b = |k| bytes.get(&(a + k)).copied();
            Some((a, u32::from_le_bytes([b(0)?, b(1)?, b(2)?, b(3)?])))
        })
        .collect()
}

/// A handler for the nesting: name, logical priority, profile.
struct Handler {
    name: String,
    priority: u8,
    profile: Profile,
}

/// The worst extra stack above a point at masking level `m`: the handlers that may preempt it
/// (priority above `m`), each at its deepest point at every level, and recursively what may
/// preempt that point. Returns the bytes and the chain of (handler, bytes it adds).
fn worst_above(m: u8, handlers: &[Handler], memo: &mut HashMap<u8, Nesting>) -> (u64, Vec<(String, u64)>) {
    if let Some(r) = memo.get(&m) {
        return r.clone();
    }
    let mut best: (u64, Vec<(String, u64)>) = (0, Vec::new());
    for h in handlers.iter().filter(|h| h.priority > m) {
        for (&(l, _), &d) in &h.profile.by_level {
            let (w, chain) = worst_above(h.priority.max(l), handlers, memo);
            let here = EXCEPTION_FRAME_BYTES + d;
            if here + w > best.0 {
                let mut c = vec![(
                    format!("{} (priority {}, at level {})", h.name, h.priority, h.priority.max(l)),
                    here,
                )];
                c.extend(chain);
                best = (here + w, c);
            }
        }
    }
    memo.insert(m, best.clone());
    best
}

/// Analyses an image given its disassembly, the hex dump of its data sections (`.rodata`,
/// `.data`), of its vector table, its static RAM size and the configuration.
pub fn analyse(
    disassembly: &str,
    data_dump: &str,
    vector_dump: &str,
    static_ram: u64,
    config: &Config,
) -> Result<StackBound, String> {
    let mut funcs = parse(disassembly);
    funcs.sort_by_key(|f| f.start);
    let taken = address_taken(&funcs, data_dump);
    let n = funcs.len();
    let mut g = Graph {
        funcs: &funcs,
        prio_bits: config.prio_bits,
        frames: vec![None; n],
        frame_busy: vec![false; n],
        taken: taken.iter().copied().collect(),
        config,
        used: vec![false; config.indirect.len()],
        memo: vec![None; n],
        busy: vec![false; n],
        sites: BTreeMap::new(),
    };
    let Roots {
        roots,
        thread,
        listed,
        unlisted,
    } = vector_roots(&mut g, vector_dump)?;
    for (h, _) in config.priorities.iter().filter(|(h, _)| !config.optional.contains(h)) {
        if !roots.iter().any(|r| r.function == *h && r.priority.is_some()) {
            return Err(format!("`priority | {h}`: no handler of that name in the vector table"));
        }
    }
    let (total, nesting) = worst_nesting(&thread, &listed, unlisted);
    let indirect = g
        .sites
        .iter()
        .map(|(&f, c)| {
            (
                short(&funcs[f].name),
                c.iter().map(|&k| short(&funcs[k].name)).collect(),
            )
        })
        .collect();
    let stale = config
        .indirect
        .iter()
        .zip(&g.used)
        .filter(|(r, u)| !**u && !r.optional)
        .map(|(r, _)| r.clone())
        .collect();
    Ok(StackBound {
        roots,
        nesting,
        total,
        indirect,
        stale,
        address_taken: taken.len(),
        static_ram,
    })
}

/// Address-taken functions (indices into `funcs`, sorted by start): Thumb addresses (bit 0 set)
/// of a function start in data, in literal pools, or from `movw`/`movt` pairs.
fn address_taken(funcs: &[Function], data_dump: &str) -> BTreeSet<usize> {
    let starts: HashMap<u64, usize> = funcs.iter().enumerate().map(|(i, f)| (f.start, i)).collect();
    let mut taken: BTreeSet<usize> = BTreeSet::new();
    let mut mark = |w: u64| {
        if w & 1 == 1 {
            if let Some(&i) = starts.get(&(w & !1)) {
                taken.insert(i);
            }
        }
    };
    for (_, w) in dump_words(data_dump) {
        mark(u64::from(w));
    }
    for f in funcs {
        let mut low: HashMap<String, u64> = HashMap::new();
        for i in &f.insns {
            if i.mnemonic == ".word" {
                if let Some(w) = immediate(&i.operands) {
                    mark(w as u64);
                }
            }
            let (base, _) = split_mnemonic(&i.mnemonic);
            if let Some((reg, imm)) = i.operands.split_once(", #") {
                let Some(v) = immediate(imm) else { continue };
                match base.as_str() {
                    "movw" => {
                        low.insert(reg.to_string(), v as u64);
                    }
                    "movt" => {
                        if let Some(l) = low.get(reg) {
                            mark(((v as u64) << 16) | l);
                        }
                    }
                    _ => {}
                }
            }
        }
    }
    taken
}

/// The system exceptions' names by vector slot (empty: reserved).
const EXCEPTIONS: [&str; 16] = [
    "",
    "Reset",
    "NMI",
    "HardFault",
    "MemManage",
    "BusFault",
    "UsageFault",
    "",
    "",
    "",
    "",
    "SVCall",
    "DebugMonitor",
    "",
    "PendSV",
    "SysTick",
];

/// The bounds of the vector table's entries: every root with its bound, thread mode's profile,
/// the handlers the configuration gives a priority, and those it does not (name, bytes with
/// the exception frame).
struct Roots {
    roots: Vec<RootBound>,
    thread: Profile,
    listed: Vec<Handler>,
    unlisted: Vec<(String, u64)>,
}

/// Bounds every function the vector table names (once each, in slot order).
fn vector_roots(g: &mut Graph, vector_dump: &str) -> Result<Roots, String> {
    let (funcs, config) = (g.funcs, g.config);
    let vector: Vec<u32> = dump_words(vector_dump).into_iter().map(|(_, w)| w).collect();
    if vector.len() < 2 {
        return Err("the vector table is empty".into());
    }
    let mut out = Roots {
        roots: Vec::new(),
        thread: Profile::default(),
        listed: Vec::new(),
        unlisted: Vec::new(),
    };
    let mut seen = BTreeSet::new();
    for (slot, &w) in vector.iter().enumerate().skip(1) {
        if w == 0 {
            continue;
        }
        let Some(fi) = containing(funcs, u64::from(w & !1)) else {
            return Err(format!("vector {slot} ({w:#x}) is outside the code"));
        };
        if !seen.insert(fi) {
            continue;
        }
        let p = g.bound(fi)?;
        let function = short(&funcs[fi].name);
        let name = match slot {
            1 => format!("Reset (thread mode): {function}"),
            2..=15 => format!("exception {slot} ({}): {function}", EXCEPTIONS[slot]),
            _ => format!("IRQ {}: {function}", slot - 16),
        };
        let priority = config.priorities.iter().find(|(h, _)| *h == function).map(|(_, p)| *p);
        let frame = if slot == 1 { 0 } else { EXCEPTION_FRAME_BYTES };
        let chain = g.chain(fi)?;
        out.roots.push(RootBound {
            name,
            function: function.clone(),
            priority: if slot == 1 { None } else { priority },
            bytes: p.max + frame,
            chain,
        });
        match (slot, priority) {
            (1, _) => out.thread = p,
            (_, Some(priority)) => out.listed.push(Handler {
                name: function,
                priority,
                profile: p,
            }),
            (_, None) => out.unlisted.push((function, p.max + EXCEPTION_FRAME_BYTES)),
        }
    }
    Ok(out)
}

/// The worst nesting: thread mode at each of its masking levels, the listed handlers that may
/// preempt it there, and the handlers the configuration does not list (faults) on top of
/// everything. Bytes, and the chain of (what, bytes it adds).
fn worst_nesting(thread: &Profile, listed: &[Handler], unlisted: Vec<(String, u64)>) -> Nesting {
    let mut memo = HashMap::new();
    let mut best: (u64, Vec<(String, u64)>) = (0, Vec::new());
    for (&(l, _), &d) in &thread.by_level {
        let (w, chain) = worst_above(l, listed, &mut memo);
        if d + w > best.0 || best.1.is_empty() {
            let mut c = vec![(format!("thread mode (at level {l})"), d)];
            c.extend(chain);
            best = (d + w, c);
        }
    }
    let (mut total, mut nesting) = best;
    for (name, b) in unlisted {
        total += b;
        nesting.push((format!("{name} (not listed: preempts everything)"), b));
    }
    (total, nesting)
}

fn run(tool: &Path, args: &[&str], elf: &Path) -> Result<String, String> {
    let out = Command::new(tool).args(args).arg(elf).output().map_err(|e| {
        format!(
            "{}: {e} (install: `rustup component add llvm-tools`, or set AEROSID_OBJDUMP)",
            tool.display()
        )
    })?;
    if !out.status.success() {
        return Err(format!(
            "{} {}: {}",
            tool.display(),
            elf.display(),
            String::from_utf8_lossy(&out.stderr)
        ));
    }
    Ok(String::from_utf8_lossy(&out.stdout).into_owned())
}

/// Analyses the image `elf` with the configuration file `config` (module doc, [`Config`]).
pub fn analyse_elf(elf: &Path, config: &Path) -> Result<StackBound, String> {
    let text = std::fs::read_to_string(config).map_err(|e| format!("{}: {e}", config.display()))?;
    let config = parse_config(&text).map_err(|e| format!("{}: {e}", config.display()))?;
    let tool = crate::panic_audit::objdump();
    let dis = run(&tool, &["-d", "--no-show-raw-insn", "-C"], elf)?;
    let data = run(&tool, &["-s", "-j", ".rodata", "-j", ".data"], elf)?;
    let vector = run(&tool, &["-s", "-j", ".vector_table"], elf)?;
    let headers = run(&tool, &["-h"], elf)?;
    // `  4 .data  00001638 20000000 08032868 DATA`: sizes of the sections that live in RAM.
    let mut static_ram = 0;
    for l in headers.lines() {
        let w: Vec<&str> = l.split_whitespace().collect();
        if w.len() >= 4 && matches!(w[1], ".data" | ".bss" | ".uninit") {
            static_ram += u64::from_str_radix(w[2], 16).map_err(|e| format!("section size `{}`: {e}", w[2]))?;
        }
    }
    analyse(&dis, &data, &vector, static_ram, &config).map_err(|e| format!("{}: {e}", elf.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    const DIS: &str = "\
08000100 <Reset>:
 8000100:      \tpush\t{r7, lr}
 8000102:      \tbl\t0x8000200 <main> @ imm = #0xfc
 8000106:      \tudf\t#0x0

08000200 <main>:
 8000200:      \tpush.w\t{r4, r5, r6, r7, r8, lr}
 8000204:      \tvpush\t{d8, d9}
 8000208:      \tsub\tsp, #0x20
 800020a:      \tcpsid i
 800020c:      \tbl\t0x8000300 <leaf> @ imm = #0xf0
 8000210:      \tcpsie i
 8000212:      \tcbz\tr0, 0x800021a <main+0x1a> @ imm = #0x4
 8000214:      \tadd\tsp, #0x20
 8000216:      \tvpop\t{d8, d9}
 8000218:      \tpop.w\t{r4, r5, r6, r7, r8, pc}
 800021a:      \tblx\tr3
 800021c:      \tbl\t0x8000500 <core::panicking::panic_fmt> @ imm = #0x2e0
 8000220:      \tb\t0x8000214 <main+0x14> @ imm = #-0x10

08000300 <leaf>:
 8000300:      \tstr\tr8, [sp, #-4]!
 8000304:      \tsub.w\tsp, sp, #0x100
 8000308:      \tadd.w\tsp, sp, #0x100
 800030c:      \tldr\tr8, [sp], #4
 8000310:      \tbx\tlr
 8000312:      \tmovs\tr0, r0
 8000314: 01 04 00 08  \t.word\t0x08000401

08000400 <callback>:
 8000400:      \tpush\t{r4, r5, r6, lr}
 8000402:      \tpop\t{r4, r5, r6, pc}

08000500 <core::panicking::panic_fmt>:
 8000500:      \tsub.w\tsp, sp, #0x1000
 8000504:      \tb\t0x8000500 <core::panicking::panic_fmt>

08000600 <HandlerA>:
 8000600:      \tpush\t{r7, lr}
 8000602:      \tmovs\tr0, #0xe0
 8000604:      \tmrs\tr1, basepri
 8000608:      \tmsr\tbasepri_max, r0
 800060c:      \tbl\t0x8000300 <leaf> @ imm = #-0x310
 8000610:      \tmsr\tbasepri, r1
 8000614:      \tpop\t{r7, pc}

08000700 <HandlerB>:
 8000700:      \tpush\t{r4, r5, r6, lr}
 8000702:      \tbl\t0x8000300 <leaf> @ imm = #-0x406
 8000706:      \tpop\t{r4, r5, r6, pc}

08000800 <Fault>:
 8000800:      \tpush\t{r7, lr}
 8000802:      \tb\t0x8000802 <Fault+0x2> @ imm = #-0x4
";

    /// Initial SP, Reset, NMI (none), HardFault → `Fault`, slots 4–15 empty, IRQ 0 → `HandlerA`,
    /// IRQ 1 → `HandlerB`.
    const VECTOR: &str = "\
Contents of section .vector_table:
 8000000 00000220 01010008 00000000 01080008  ................
 8000010 00000000 00000000 00000000 00000000  ................
 8000020 00000000 00000000 00000000 00000000  ................
 8000030 00000000 00000000 00000000 00000000  ................
 8000040 01060008 01070008                    ........
";

    const CONFIG: &str = "\
# test
prio-bits | 4 | as the STM32F4
priority | HandlerA | 1 | t
priority | HandlerB | 2 | t
indirect | main | callback | the only callback
";

    #[test]
    fn frames_calls_masking_and_preemption_add_up() {
        let config = parse_config(CONFIG).expect("config");
        let b = analyse(DIS, "", VECTOR, 1000, &config).expect("analysis");
        let r = b.report();
        // main: 24 (push.w) + 16 (vpush) + 32 (sub) = 72 in use at its calls; leaf: 4 + 256 = 260;
        // the indirect call reaches `callback` (its address is a literal in `leaf`): 16; the panic
        // entry is not followed. Reset alone: 8 + 72 + 260 = 340, with interrupts masked.
        assert_eq!(b.roots[0].bytes, 340, "{r}");
        assert_eq!(b.roots[0].chain.len(), 3, "{r}");
        assert_eq!(b.roots[0].chain[2], ("leaf".to_string(), 80));
        let alone: Vec<u64> = b.roots.iter().map(|r| r.bytes).collect();
        let f = EXCEPTION_FRAME_BYTES;
        assert_eq!(alone, vec![340, 8 + f, 8 + 260 + f, 16 + 260 + f], "{r}");
        // Nesting: thread mode unmasked is at most 8 + 72 + 16 = 96 deep (the callback, after
        // `cpsie`); HandlerA (priority 1) preempts it, HandlerB (2) preempts HandlerA only outside
        // HandlerA's BASEPRI lock (ceiling 2, `0xe0`), i.e. at HandlerA's depth 8, not at its 268;
        // the unlisted fault handler goes on top of everything.
        assert_eq!(b.total, 96 + (f + 8) + (f + 276) + (f + 8), "{r}");
        assert_eq!(b.nesting.len(), 4, "{r}");
        assert_eq!(b.ram(), 1000 + b.total);
        assert_eq!(b.address_taken, 1);
        assert_eq!(b.indirect, vec![("main".to_string(), vec!["callback".to_string()])]);
        assert!(b.stale.is_empty());
        // Without the lock HandlerB could preempt HandlerA at its deepest point.
        let unlocked = DIS.replace("msr\tbasepri_max, r0", "nop");
        let u = analyse(&unlocked, "", VECTOR, 0, &config).expect("analysis");
        assert_eq!(u.total, 96 + (f + 268) + (f + 276) + (f + 8), "{}", u.report());
    }

    #[test]
    fn a_conditional_call_to_a_lock_does_not_mask_the_path_that_skips_it() {
        // HandlerA calls `acquire` (a critical section: returns masked) only if `eq`, then calls
        // leaf: on the path that skipped the call HandlerB may still preempt leaf.
        let cfg = format!("{CONFIG}critical-section | acquire | release | t\n");
        let config = parse_config(&cfg).expect("config");
        let dis = DIS
            .replace(
                " 8000608:      \tmsr\tbasepri_max, r0\n",
                " 8000608:      \tit\teq\n 800060a:      \tbleq\t0x8000900 <acquire>\n",
            )
            .replace(
                "08000800 <Fault>:",
                "08000900 <acquire>:\n 8000900:      \tcpsid i\n 8000902:      \tbx\tlr\n\n08000800 <Fault>:",
            );
        let b = analyse(&dis, "", VECTOR, 0, &config).expect("analysis");
        let f = EXCEPTION_FRAME_BYTES;
        assert_eq!(b.total, 96 + (f + 268) + (f + 276) + (f + 8), "{}", b.report());
    }

    #[test]
    fn unresolved_or_wrong_configuration_is_an_error_and_unused_lines_are_stale() {
        let base = "prio-bits | 4 | t\npriority | HandlerA | 1 | t\npriority | HandlerB | 2 | t\n";
        let e = analyse(DIS, "", VECTOR, 0, &parse_config(base).expect("config")).expect_err("unresolved");
        assert!(e.contains("does not resolve"), "{e}");
        let wrong = parse_config(&format!("{base}indirect | main | leaf | not address-taken")).expect("config");
        let e = analyse(DIS, "", VECTOR, 0, &wrong).expect_err("wrong callee");
        assert!(e.contains("no address-taken function"), "{e}");
        let extra = parse_config(&format!("{CONFIG}indirect | nowhere | callback | old")).expect("config");
        let b = analyse(DIS, "", VECTOR, 0, &extra).expect("analysis");
        assert_eq!(b.stale.len(), 1);
        let optional =
            parse_config(&format!("{CONFIG}indirect? | nowhere | callback | one board only")).expect("config");
        let b = analyse(DIS, "", VECTOR, 0, &optional).expect("analysis");
        assert!(b.stale.is_empty(), "an unused `indirect?` line is not stale");
        let missing = parse_config(&format!("{CONFIG}priority | NoSuchHandler | 3 | t")).expect("config");
        let e = analyse(DIS, "", VECTOR, 0, &missing).expect_err("unknown handler");
        assert!(e.contains("NoSuchHandler"), "{e}");
        assert!(parse_config("indirect | two | fields").is_err());
        assert!(parse_config("priority | H | 0 | zero is not a task priority\nprio-bits | 4 | t").is_err());
        assert!(parse_config("indirect | a | b | c").is_err(), "prio-bits is required");
    }

    #[test]
    fn an_unknown_write_to_sp_and_recursion_are_errors_not_low_bounds() {
        let config = parse_config(CONFIG).expect("config");
        let bad = DIS.replace("sub\tsp, #0x20", "mov\tsp, r4");
        let e = analyse(&bad, "", VECTOR, 0, &config).expect_err("unknown idiom");
        assert!(e.contains("unrecognised write to sp"), "{e}");
        // A jump-table entry that is not an instruction.
        let table = DIS.replace(
            " 8000802:      \tb\t0x8000802 <Fault+0x2> @ imm = #-0x4\n",
            " 8000802:      \ttbb\t[pc, r0]\n 8000806: 03 00  \t.short\t0x0003\n 8000808:      \tb\t0x8000808 <Fault+0x8>\n",
        );
        let e = analyse(&table, "", VECTOR, 0, &config).expect_err("bad table");
        assert!(e.contains("jump-table entry"), "{e}");
        // A table followed by its padding and a constant island (no index bound beside the
        // `tbb`): the zero entry points into the table, so the table ends before it and the
        // island's bytes are not taken as entries.
        let island = DIS.replace(
            " 8000802:      \tb\t0x8000802 <Fault+0x2> @ imm = #-0x4\n",
            " 8000802:      \ttbb\t[pc, r0]\n 8000806: 02 00  \t.short\t0x0002\n 8000808: bf 05  \t.short\t0x05bf\n 800080a:      \tb\t0x800080a <Fault+0xa>\n",
        );
        analyse(&island, "", VECTOR, 0, &config).expect("the table's one entry resolves");
        let rec = DIS.replace("bl\t0x8000300 <leaf> @ imm = #-0x406", "bl\t0x8000700 <HandlerB>");
        let e = analyse(&rec, "", VECTOR, 0, &config).expect_err("recursion");
        assert!(e.contains("recursion"), "{e}");
    }

    #[test]
    fn mnemonics_split_into_base_and_condition() {
        assert_eq!(split_mnemonic("bne.w"), ("b".into(), true));
        assert_eq!(split_mnemonic("bl"), ("bl".into(), false));
        assert_eq!(split_mnemonic("bls"), ("b".into(), true));
        assert_eq!(split_mnemonic("poplo"), ("pop".into(), true));
        assert_eq!(split_mnemonic("pop.w"), ("pop".into(), false));
        assert_eq!(split_mnemonic("vpush"), ("vpush".into(), false));
        assert_eq!(split_mnemonic("movs"), ("movs".into(), false));
        assert_eq!(split_mnemonic("moveq"), ("mov".into(), true));
        assert_eq!(split_mnemonic("bleq"), ("bl".into(), true));
        assert_eq!(list_bytes("{s16-s31}").expect("list"), (64, false));
        assert_eq!(list_bytes("{r4, r5, r7, pc}").expect("list"), (16, true));
        assert_eq!(stack_effect("ldm", "sp, {r0, r2, r3}"), Ok((0, false)));
        assert_eq!(stack_effect("ldm", "sp!, {r4, pc}"), Ok((-8, true)));
        assert!(stack_effect("mov", "sp, r7").is_err());
        // Forms the analysis does not model fail rather than count as nothing.
        assert!(stack_effect("stmia", "sp!, {r0, r1}").is_err());
        assert!(stack_effect("ldmdb", "sp!, {r0, r1}").is_err());
        assert!(stack_effect("ldm", "r0, {r4, pc}").is_err());
        assert!(stack_effect("msr", "msp, r0").is_err());
    }
}
