//! The command lines' standard output: `sim-host ... | head` and `hil ... | head` end
//! quietly with exit code 0 when the reader closes the pipe, as Unix tools do
//! (`println!` panics there: Rust ignores `SIGPIPE`, so the write fails with `EPIPE`).

use std::io::Write as _;

/// Writes `args` to standard output (see the module docs for the failures).
pub fn write(args: std::fmt::Arguments<'_>) {
    let mut out = std::io::stdout().lock();
    if let Err(e) = out.write_fmt(args).and_then(|()| out.flush()) {
        failed(&e);
    }
}

/// Ends the program after a failed write to stdout: 0 on a closed pipe, else 1 with the reason.
pub fn failed(e: &std::io::Error) -> ! {
    if e.kind() == std::io::ErrorKind::BrokenPipe {
        std::process::exit(0);
    }
    eprintln!("error: cannot write to standard output: {e}");
    std::process::exit(1);
}

/// `print!` that ends the program quietly with success on a closed pipe ([`write`](fn@write)).
#[macro_export]
macro_rules! out {
    ($($t:tt)*) => {
        $crate::out::write(format_args!($($t)*))
    };
}

/// `println!` that ends the program quietly with success on a closed pipe ([`write`](fn@write)).
#[macro_export]
macro_rules! outln {
    () => {
        $crate::out::write(format_args!("\n"))
    };
    ($($t:tt)*) => {
        $crate::out::write(format_args!("{}\n", format_args!($($t)*)))
    };
}
