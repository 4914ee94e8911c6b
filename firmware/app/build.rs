//! 1. The default controller, compiled: discretises and quantises the default
//!    configuration with the firmware's own control code (`wheelset-control`, f64 then
//!    quantised for the build's sample type) and writes it as exact constants
//!    (`$OUT_DIR/default_runtime.rs`, a `wheelset_runtime::RuntimeBits`), so the device
//!    starts without any float maths. Host builds too (their tests check the constants).
//! 2. Link set-up for the board binaries: puts the board's `memory.x` (and, for QEMU, the
//!    interrupt names of the crate's own vector table in `device.x`) on the linker search
//!    path and passes the cortex-m-rt and defmt linker scripts. Nothing on the host.

use std::{env, fs, path::PathBuf};

use wheelset_runtime::{RuntimeBits, RuntimeConfig};

/// The default runtime, compiled for the build's sample type, as Rust source.
fn default_runtime() -> String {
    let cfg = RuntimeConfig::default();
    let bits = if env::var_os("CARGO_FEATURE_F32").is_some() {
        RuntimeBits::try_new::<f32>(&cfg)
    } else {
        RuntimeBits::try_new::<wheelset_control::Fx>(&cfg)
    };
    match bits {
        // The derived `Debug` of these plain structs (integers, bools, arrays, a unit
        // enum) is Rust expression syntax; the host test `default_runtime_is_compiled`
        // checks the constant against a fresh compilation.
        Ok(b) => format!("pub const DEFAULT_RUNTIME: RuntimeBits = {b:#?};\n"),
        Err(e) => {
            println!("cargo:warning=the default configuration does not compile: {e}");
            std::process::exit(1);
        }
    }
}

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rerun-if-env-changed=CARGO_FEATURE_F32");
    let out = PathBuf::from(env::var_os("OUT_DIR").unwrap_or_default());
    if let Err(e) = fs::write(out.join("default_runtime.rs"), default_runtime()) {
        println!("cargo:warning=cannot write default_runtime.rs: {e}");
        std::process::exit(1);
    }
    println!("cargo:rerun-if-changed=../../memory.x");
    println!("cargo:rerun-if-changed=qemu/memory-qemu.x");
    println!("cargo:rerun-if-changed=qemu/device.x");
    println!("cargo:rerun-if-changed=qemu/link.x");
    if env::var("CARGO_CFG_TARGET_OS").as_deref() != Ok("none") {
        return;
    }
    let nucleo = env::var_os("CARGO_FEATURE_BOARD_NUCLEO").is_some();
    let qemu = env::var_os("CARGO_FEATURE_BOARD_QEMU").is_some();
    let manifest = PathBuf::from(env::var_os("CARGO_MANIFEST_DIR").unwrap_or_default());
    let copy = |from: PathBuf, to: &str| {
        if let Err(e) = fs::copy(&from, out.join(to)) {
            println!("cargo:warning=cannot copy {}: {e}", from.display());
            std::process::exit(1);
        }
    };
    // The linker runs in the workspace root and looks there first for an INCLUDEd file,
    // so the QEMU map cannot be called `memory.x` (the top-level STM32 one would win):
    // the QEMU build uses its own copy of cortex-m-rt's link.x that includes
    // `memory-qemu.x` (see qemu/link.x).
    let script = match (nucleo, qemu) {
        (true, false) => {
            copy(manifest.join("../../memory.x"), "memory.x");
            "link.x"
        }
        (false, true) => {
            copy(manifest.join("qemu/memory-qemu.x"), "memory-qemu.x");
            copy(manifest.join("qemu/device.x"), "device.x");
            copy(manifest.join("qemu/link.x"), "link-qemu.x");
            "link-qemu.x"
        }
        // The library's compile_error! explains the feature choice; no link set-up.
        _ => return,
    };
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rustc-link-arg-bins=--nmagic");
    // Identical code folding (rust-lld): the generic runtime is instantiated per message
    // and sample type, and many copies are identical; folding them saves flash
    // (`cargo fw` prints the sizes).
    println!("cargo:rustc-link-arg-bins=--icf=all");
    println!("cargo:rustc-link-arg-bins=-T{script}");
    println!("cargo:rustc-link-arg-bins=-Tdefmt.x");
}
