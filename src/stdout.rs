//! What the commands print on stdout: `outln!` and `out!`, `println!` and `print!` that end the
//! program quietly when the reader has closed the pipe.

/// `println!` for what a command prints on stdout, through [`write_stdout`].
macro_rules! outln {
    ($($arg:tt)*) => {
        $crate::stdout::write_stdout(format_args!($($arg)*), true)
    };
}

/// `print!` through [`write_stdout`].
macro_rules! out {
    ($($arg:tt)*) => {
        $crate::stdout::write_stdout(format_args!($($arg)*), false)
    };
}

/// Writes one piece of a command's output to stdout (and a newline with `newline`). A reader
/// that stops early (`lodestar compare A B | head -1`) closes the pipe and the write fails
/// with `BrokenPipe`: the program then ends at once with status 0, as the reader wanted no
/// more, where `println!` would panic. Any other failure to write is an error (status 1).
pub fn write_stdout(args: std::fmt::Arguments, newline: bool) {
    use std::io::Write;
    let mut stdout = std::io::stdout().lock();
    let written = stdout
        .write_fmt(args)
        .and_then(|()| {
            if newline {
                stdout.write_all(b"\n")
            } else {
                Ok(())
            }
        })
        .and_then(|()| stdout.flush());
    if let Err(e) = written {
        if e.kind() == std::io::ErrorKind::BrokenPipe {
            std::process::exit(0);
        }
        eprintln!("lodestar: cannot write to stdout: {e}");
        std::process::exit(1);
    }
}
