//! The `trimorph` command-line tool; see `trimorph --help`.

/// Large buffers (images, maps, encoded files) on transparent huge pages: fewer page faults
/// in whole-image jobs ([`trimorph::alloc`]).
#[global_allocator]
static ALLOC: trimorph::alloc::HugePages = trimorph::alloc::HugePages;

fn main() {
    trimorph::alloc::tune_heap();
    std::process::exit(trimorph::cli::run());
}
