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
