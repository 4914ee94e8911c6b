//! The embassy firmware binary. On the host it only explains how to build it.
fn main() {
    println!("wheelset-fw runs on a microcontroller: build it with `cargo fw`");
}
