//! Command results on standard output, without a panic when the reader has gone away
//! (`hevo eval ... --failures | head`). `println!` panics on a closed pipe; commands print
//! through [`outln!`](crate::outln) instead, whose [`StdoutClosed`] error ends the command
//! quietly and successfully, as a closed pipe ends other Unix tools.

use std::io::Write;

/// Standard output was closed by its reader; nothing more can be printed.
#[derive(Debug, thiserror::Error)]
#[error("standard output was closed")]
pub struct StdoutClosed;

/// Writes one line to standard output. A closed pipe is [`StdoutClosed`]; any other write error
/// is returned as it is.
pub fn write_line(args: std::fmt::Arguments<'_>) -> anyhow::Result<()> {
    let mut stdout = std::io::stdout().lock();
    match writeln!(stdout, "{args}").and_then(|()| stdout.flush()) {
        Ok(()) => Ok(()),
        Err(error) if error.kind() == std::io::ErrorKind::BrokenPipe => Err(StdoutClosed.into()),
        Err(error) => Err(anyhow::Error::new(error).context("writing to standard output")),
    }
}

/// `println!` for commands: returns early with the write's error (see the module docs).
#[macro_export]
macro_rules! outln {
    ($($arg:tt)*) => {
        $crate::output::write_line(format_args!($($arg)*))?
    };
}
