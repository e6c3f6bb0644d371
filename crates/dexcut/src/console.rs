//! Console output that never panics: a closed stdout (`dexcut calibrate m.csv | true`)
//! ends the output quietly instead of aborting the command.

use std::io::Write;

/// Write one line to stdout; a closed or failing stdout is ignored (the
/// results are in files, the console only repeats them).
pub fn line(args: std::fmt::Arguments) {
    let mut out = std::io::stdout().lock();
    let _ = out.write_fmt(args).and_then(|()| out.write_all(b"\n"));
}

/// `println!` that does not panic on a closed pipe.
#[macro_export]
macro_rules! outln {
    ($($arg:tt)*) => {
        $crate::console::line(format_args!($($arg)*))
    };
}

/// The message of an error and its causes, each cause once (an I/O error
/// wrapped by a CSV or JSON error would otherwise print twice).
pub fn error_message(e: &anyhow::Error) -> String {
    let mut msg = String::new();
    for cause in e.chain() {
        let text = cause.to_string();
        if msg.contains(&text) {
            continue;
        }
        if !msg.is_empty() {
            msg.push_str(": ");
        }
        msg.push_str(&text);
    }
    msg
}
