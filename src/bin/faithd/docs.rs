//! Manual pages and shell completions, generated from the command line's own
//! definition so they cannot drift from it. The .deb ships both
//! (`debian/build-deb`); `faithd completions SHELL` prints a script for a user's shell.

use std::io;
use std::path::{Path, PathBuf};

use clap::Command;

/// Writes one page per command into `dir`: `faithd.1`, `faithd-run.1`,
/// `faithd-bench-foe.1`, ... (the `git-commit` convention `man faithd-run` finds).
/// Hidden commands get none. Returns the pages written.
pub fn write_man_pages(cli: Command, dir: &Path) -> io::Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir)?;
    let mut cli = cli;
    // Building fills in every subcommand's usage line with its full name.
    cli.build();
    let mut pages = Vec::new();
    write_page(&cli, "faithd", dir, &mut pages)?;
    Ok(pages)
}

fn write_page(
    command: &Command,
    page_name: &str,
    dir: &Path,
    pages: &mut Vec<PathBuf>,
) -> io::Result<()> {
    let path = dir.join(format!("{page_name}.1"));
    let mut roff = Vec::new();
    // The page is titled after its file, so `man faithd-run` shows FAITHD-RUN(1).
    let named = command.clone().name(page_name.to_string());
    clap_mangen::Man::new(named).render(&mut roff)?;
    std::fs::write(&path, roff)?;
    pages.push(path);
    // clap's own `help` subcommand is documented by every page's usage.
    for sub in command
        .get_subcommands()
        .filter(|s| !s.is_hide_set() && s.get_name() != "help")
    {
        let sub_page = format!("{page_name}-{}", sub.get_name());
        write_page(sub, &sub_page, dir, pages)?;
    }
    Ok(())
}

/// Writes `shell`'s completion script for `faithd` to standard output.
pub fn print_completions(cli: Command, shell: clap_complete::Shell) {
    let mut cli = cli;
    clap_complete::generate(shell, &mut cli, "faithd", &mut io::stdout());
}
