//! `hapticctl manual DIR`: the manual pages, written from [`hapticctl::manual`].

use std::path::Path;

use clap::CommandFactory;
use hapticctl::manual::{page_date, pages};

use crate::Failure;

/// Write every page into `dir`.
pub fn write(dir: &Path) -> Result<(), Failure> {
    let failed = |e: std::io::Error| Failure::failed(format!("{}: {e}", dir.display()));
    std::fs::create_dir_all(dir).map_err(failed)?;
    for (file, page) in pages(crate::Cli::command(), &page_date()) {
        std::fs::write(dir.join(file), page).map_err(failed)?;
    }
    Ok(())
}
