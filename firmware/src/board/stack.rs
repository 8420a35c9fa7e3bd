//! Stack high-water mark by painting: at boot every word between the end of the static RAM
//! (`.bss`/`.uninit`, cortex-m-rt's `__sheap`) and a margin below the current stack pointer is set
//! to a pattern; later the lowest word no longer holding it bounds the deepest stack use. The
//! stack grows down from the top of RAM (`_stack_start`); there is no heap.

/// The paint.
const PAINT: u32 = 0xDEAD_BEEF;
/// Words left unpainted below the stack pointer at the time of painting (the painter's own frame).
const MARGIN_WORDS: usize = 64;

extern "C" {
    static __sheap: u32;
    static _stack_start: u32;
}

fn bounds() -> (usize, usize) {
    // Only the addresses of the linker symbols are taken, never their values.
    let bottom = core::ptr::addr_of!(__sheap) as usize;
    let top = core::ptr::addr_of!(_stack_start) as usize;
    (bottom, top)
}

/// Paints the free stack. Call once, early in `init`.
pub fn paint() {
    let (bottom, _) = bounds();
    let sp = cortex_m::register::msp::read() as usize;
    let end = sp.saturating_sub(MARGIN_WORDS * 4);
    let mut p = bottom;
    while p < end {
        // SAFETY: [bottom, sp − margin) is RAM that nothing uses: above every static (`__sheap` is
        // the end of .bss/.uninit and there is no heap) and below the live stack; word-aligned.
        unsafe { core::ptr::write_volatile(p as *mut u32, PAINT) };
        p += 4;
    }
}

/// Deepest stack use since [`paint`], bytes (from the top of RAM down to the lowest overwritten word).
pub fn high_water_bytes() -> u32 {
    let (bottom, top) = bounds();
    let mut p = bottom;
    while p < top {
        // SAFETY: reading a word of RAM between the statics and the top of the stack.
        if unsafe { core::ptr::read_volatile(p as *const u32) } != PAINT {
            break;
        }
        p += 4;
    }
    (top - p) as u32
}
