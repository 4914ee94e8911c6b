//! 1. The default controller, compiled: discretises and quantises the default
//!    configuration with the firmware's own control code (`wheelset-control`, f64 then
//!    quantised for the build's sample type) and writes it as exact constants
//!    (`$OUT_DIR/default_runtime.rs`, a `wheelset_runtime::RuntimeBits`), so the device
//!    starts without any float maths. Host builds too (their tests check the constants).
//! 2. Link set-up for the board build (nothing on the host): the board is the one
//!    `board-<name>` feature, its memory map `src/board/<name>/memory.x` ([`link_setup`]).
use std::{
    env, fs,
    path::{Path, PathBuf},
};

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
    if env::var("CARGO_CFG_TARGET_OS").as_deref() == Ok("none") {
        if let Err(e) = link_setup(&out) {
            println!("cargo:warning={e}");
            std::process::exit(1);
        }
    }
}

/// The board's memory map on the link, and the linker scripts.
///
/// cortex-m-rt's `link.x` starts with `INCLUDE memory.x`, and the linker (run in the
/// workspace root) takes an included file from its working directory before any search
/// path: the top-level `memory.x`, the Nucleo-F446RE's. A board without a map of its
/// own links with it as it is. A board with its own map links with
/// `$OUT_DIR/link-<name>.x`: its map, then `INCLUDE link.x`; and lld's `--remap-inputs`
/// turns every `memory.x` the linker opens into an empty script, so the top-level map
/// plays no part. flip-link (the STM32 boards' linker) finds the RAM region in that same
/// first script and links its flipped image with its own copy of it.
/// `src/board/<name>/device.x`, if there is one, names the board's interrupt handlers
/// for cortex-m-rt's `device` feature. `cargo fw` checks every ELF's sections against
/// its own board's map.
fn link_setup(out: &Path) -> Result<(), String> {
    let boards: Vec<String> = env::vars()
        .filter_map(|(k, _)| Some(k.strip_prefix("CARGO_FEATURE_BOARD_")?.to_lowercase()))
        .collect();
    let [board] = boards.as_slice() else {
        return Err(format!(
            "the firmware needs exactly one `board-*` feature (firmware/app/Cargo.toml), \
             not {boards:?}: use `cargo fw`"
        ));
    };
    let manifest = PathBuf::from(env::var_os("CARGO_MANIFEST_DIR").unwrap_or_default());
    let dir = manifest.join("src/board").join(board);
    let write = |name: &str, text: &str| {
        fs::write(out.join(name), text).map_err(|e| format!("cannot write {name}: {e}"))
    };
    let read = |path: &Path| {
        println!("cargo:rerun-if-changed={}", path.display());
        fs::read_to_string(path).map_err(|e| format!("cannot read {}: {e}", path.display()))
    };
    if dir.join("device.x").exists() {
        write("device.x", &read(&dir.join("device.x"))?)?;
    }
    let script = if dir.join("memory.x").exists() {
        let script = format!("link-{board}.x");
        write(
            &script,
            &(read(&dir.join("memory.x"))? + "\nINCLUDE link.x\n"),
        )?;
        let none = out.join("memory-none.x");
        write(
            "memory-none.x",
            "/* The top-level memory.x, remapped away (build.rs). */\n",
        )?;
        for pattern in ["memory.x", "*/memory.x"] {
            println!(
                "cargo:rustc-link-arg-bins=--remap-inputs={pattern}={}",
                none.display()
            );
        }
        script
    } else {
        write("memory.x", &read(&manifest.join("../../memory.x"))?)?;
        "link.x".to_string()
    };
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rustc-link-arg-bins=--nmagic");
    // Identical code folding (rust-lld): the generic runtime is instantiated per message
    // and sample type, and many copies are identical; folding them saves flash
    // (`cargo fw` prints the sizes).
    println!("cargo:rustc-link-arg-bins=--icf=all");
    println!("cargo:rustc-link-arg-bins=-T{script}");
    println!("cargo:rustc-link-arg-bins=-Tdefmt.x");
    Ok(())
}
