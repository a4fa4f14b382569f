//! `trimorph editor [DEF.json] [--model M.obj] [--image FRAME | --moving M --fixed F]
//! [--port 8080]`: the local web editor ([`crate::server`]), starting from [`crate::server::start::initial_doc`].

use crate::server::start::{initial_doc, StartOptions};
use crate::server::Server;
use anyhow::Result;
use std::io::Write;

/// Runs the editor on `port` until the process is stopped (Ctrl-C).
pub fn run(start: &StartOptions, port: u16) -> Result<()> {
    let root = std::env::current_dir()?;
    let mut doc = initial_doc(start, &root)?;
    let server = Server::bind(port)?;
    // Printing must not fail the server: whoever started it may close our stdout once it
    // has read the address (tests/it/cli/editor_cmd.rs does).
    let mut out = std::io::stdout();
    let _ = writeln!(out, "trimorph editor at {} (files: {})", server.url(), root.display());
    let _ = writeln!(
        out,
        "Open that address (the token in it is this session's key; keep it private). \
         Ctrl-C stops the editor; save first (Ctrl+S in the page)."
    );
    let _ = out.flush();
    server.run(&mut doc, &|| false);
    Ok(())
}
