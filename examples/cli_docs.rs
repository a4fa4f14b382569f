//! Writes the command-line reference pages into `docs/cli/` (see
//! `trimorph::cli::reference`) and removes `*.md` pages there that are no longer generated:
//! `cargo run --example cli_docs`.

use std::{collections::HashSet, fs, path::Path};

fn main() -> std::io::Result<()> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/cli");
    fs::create_dir_all(&dir)?;
    let pages = trimorph::cli::reference::pages();
    let names: HashSet<&str> = pages.iter().map(|(n, _)| n.as_str()).collect();
    for entry in fs::read_dir(&dir)? {
        let path = entry?.path();
        let name = path.file_name().and_then(|n| n.to_str()).unwrap_or_default();
        if path.extension().is_some_and(|e| e == "md") && !names.contains(name) {
            fs::remove_file(&path)?;
            println!("removed {}", path.display());
        }
    }
    for (name, text) in &pages {
        fs::write(dir.join(name), text)?;
    }
    println!("wrote {} pages into {}", pages.len(), dir.display());
    Ok(())
}
