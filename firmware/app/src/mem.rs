//! `memcpy` and `memset` (and their ARM EABI entry points) for the firmware, in a few
//! dozen bytes of Thumb-2 instead of `compiler_builtins`' unrolled versions.
//!
//! Why: `compiler_builtins`' `memcpy` with its `__aeabi_memcpy4/8` and
//! `__aeabi_memclr4/8` variants take over a kilobyte of the Nucleo build's flash, these
//! a tenth of it (`arm-none-eabi-nm -S --size-sort target/fw/wheelset-nucleo.elf`). The frames the firmware copies and clears are at most `MAX_FRAME` bytes, so
//! the unrolling bought little: the loops here move a word per 4 instructions when both
//! pointers are word aligned (every call the compiler makes through the `4`/`8` entry
//! points, and the frame buffers), a byte per 4 instructions otherwise.
//!
//! Written in assembly, not Rust: a Rust loop that copies bytes is recognised by LLVM
//! as a `memcpy` idiom and compiled into a call to `memcpy` itself. The symbols are
//! global, so the linker takes them and never pulls `compiler_builtins`' ones in.
//!
//! Contracts (AAPCS; the C library's and the ARM run-time ABI's):
//! - `memcpy(dst r0, src r1, n r2) -> dst`; `__aeabi_memcpy{,4,8}(dst, src, n)` (4/8:
//!   both pointers aligned to 4/8). Regions must not overlap (no `memmove` here: the
//!   firmware does not reference it; a reference would fail to link, not misbehave).
//! - `memset(dst r0, c r1, n r2) -> dst`; `__aeabi_memset{,4,8}(dst r0, n r1, c r2)`
//!   (note the order); `__aeabi_memclr{,4,8}(dst r0, n r1)`.
//!
//! Clobbers only r0-r3 and r12 (caller-saved), no stack. Cortex-M3/M4 (Thumb-2,
//! `IT` blocks, post-indexed loads and stores). Exercised by every firmware run: the
//! QEMU smoke and closed-loop tests compare the device's frames with the host's bit for
//! bit.

// SAFETY: the symbols below implement the C and ARM EABI contracts stated above
// (checked by every firmware run); nothing else in the program defines them.
core::arch::global_asm!(
    ".section .text.wheelset_mem,\"ax\",%progbits",
    ".syntax unified",
    ".thumb",
    ".p2align 1",
    // memcpy: word loop when both pointers are word aligned, then bytes.
    ".global memcpy",
    ".global __aeabi_memcpy",
    ".global __aeabi_memcpy4",
    ".global __aeabi_memcpy8",
    ".type memcpy,%function",
    ".type __aeabi_memcpy,%function",
    ".type __aeabi_memcpy4,%function",
    ".type __aeabi_memcpy8,%function",
    ".thumb_func",
    "memcpy:",
    ".thumb_func",
    "__aeabi_memcpy:",
    "    orr   r3, r0, r1",
    "    lsls  r3, r3, #30",
    "    bne   .Lwheelset_cpy_bytes",
    ".thumb_func",
    "__aeabi_memcpy4:",
    ".thumb_func",
    "__aeabi_memcpy8:",
    "    mov   r12, r0",
    ".Lwheelset_cpy_words:",
    "    subs  r2, r2, #4",
    "    itt   hs",
    "    ldrhs r3, [r1], #4",
    "    strhs r3, [r0], #4",
    "    bhs   .Lwheelset_cpy_words",
    "    adds  r2, r2, #4",
    "    b     .Lwheelset_cpy_tail",
    ".Lwheelset_cpy_bytes:",
    "    mov   r12, r0",
    ".Lwheelset_cpy_tail:",
    "    subs  r2, r2, #1",
    "    itt   hs",
    "    ldrbhs r3, [r1], #1",
    "    strbhs r3, [r0], #1",
    "    bhs   .Lwheelset_cpy_tail",
    "    mov   r0, r12",
    "    bx    lr",
    ".size memcpy, . - memcpy",
    // memclr / memset (EABI argument order) -> memset's (dst, c, n).
    ".global __aeabi_memclr",
    ".global __aeabi_memclr4",
    ".global __aeabi_memclr8",
    ".global __aeabi_memset",
    ".global __aeabi_memset4",
    ".global __aeabi_memset8",
    ".global memset",
    ".type __aeabi_memclr,%function",
    ".type __aeabi_memclr4,%function",
    ".type __aeabi_memclr8,%function",
    ".type __aeabi_memset,%function",
    ".type __aeabi_memset4,%function",
    ".type __aeabi_memset8,%function",
    ".type memset,%function",
    ".thumb_func",
    "__aeabi_memclr:",
    ".thumb_func",
    "__aeabi_memclr4:",
    ".thumb_func",
    "__aeabi_memclr8:",
    "    movs  r2, #0",
    ".thumb_func",
    "__aeabi_memset:",
    ".thumb_func",
    "__aeabi_memset4:",
    ".thumb_func",
    "__aeabi_memset8:",
    // (dst, n, c) -> (dst, c, n)
    "    mov   r3, r1",
    "    mov   r1, r2",
    "    mov   r2, r3",
    ".thumb_func",
    "memset:",
    "    mov   r12, r0",
    "    uxtb  r1, r1",
    "    orr   r1, r1, r1, lsl #8",
    "    orr   r1, r1, r1, lsl #16",
    "    lsls  r3, r0, #30",
    "    bne   .Lwheelset_set_tail",
    ".Lwheelset_set_words:",
    "    subs  r2, r2, #4",
    "    it    hs",
    "    strhs r1, [r0], #4",
    "    bhs   .Lwheelset_set_words",
    "    adds  r2, r2, #4",
    ".Lwheelset_set_tail:",
    "    subs  r2, r2, #1",
    "    it    hs",
    "    strbhs r1, [r0], #1",
    "    bhs   .Lwheelset_set_tail",
    "    mov   r0, r12",
    "    bx    lr",
    ".size memset, . - memset",
);
