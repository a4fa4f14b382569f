//! The `trimorph` command-line tool; see `trimorph --help`.

fn main() {
    std::process::exit(trimorph::cli::run());
}
