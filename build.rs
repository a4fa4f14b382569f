//! Build script: links the `trimorph` executable position-dependent (`-no-pie`) on
//! x86-64 GNU/Linux.
//!
//! A position-independent executable of this size carries about 34,000 relative
//! relocations that the loader applies at every start, writing (and so copying) each page
//! of relocated data: 386 page faults and 2.8 ms for `trimorph --version` against 246 and
//! 1.9 ms linked position-dependent (`perf stat -r 100`). Small jobs (`trimorph solve` of a
//! 400 x 800 system takes about 30 ms) feel that. Only the executable is affected: the
//! library, the Python extension (a shared object) and the test binaries link as before.

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    let var = |k: &str| std::env::var(k).unwrap_or_default();
    if var("CARGO_CFG_TARGET_OS") == "linux"
        && var("CARGO_CFG_TARGET_ARCH") == "x86_64"
        && var("CARGO_CFG_TARGET_ENV") == "gnu"
    {
        println!("cargo:rustc-link-arg-bins=-no-pie");
    }
}
