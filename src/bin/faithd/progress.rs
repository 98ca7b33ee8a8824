//! Progress on standard error for the lab's long runs and the videos: a bar on a
//! terminal, one line per item done in a pipe.

/// A progress bar on standard error when it is a terminal; hidden (and silent) in
/// a pipe or a file.
pub fn progress_bar(len: u64, what: &str) -> indicatif::ProgressBar {
    let bar = indicatif::ProgressBar::new(len);
    bar.set_style(
        indicatif::ProgressStyle::with_template(&format!(
            "{{bar:40}} {{pos}}/{{len}} {what}, {{elapsed}} elapsed, about {{eta}} left"
        ))
        .expect("progress template"),
    );
    bar
}

/// One item done: its line above the bar on a terminal, or alone in a pipe.
pub fn step(progress: &indicatif::ProgressBar, line: String) {
    if progress.is_hidden() {
        eprintln!("{line}");
    } else {
        progress.println(line);
    }
    progress.inc(1);
}
