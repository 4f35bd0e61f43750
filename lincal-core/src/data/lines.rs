//! The lines of a data file: read one at a time (at most [`MAX_LINE`] bytes), checked as
//! UTF-8, blank lines and `#` comments skipped.

use std::io::{BufRead, Read};

use super::cells::at;
use crate::error::{Error, Result};

/// Longest line of a data file, in bytes (a row of 20 joints and a tip is under 1 KiB).
pub const MAX_LINE: usize = 1 << 16;

/// Reads the next line into `buf` (cleared first), never more than [`MAX_LINE`] bytes of
/// it; returns the bytes read, 0 at the end. `line` is the number the line will have.
pub(super) fn read_line<R: BufRead>(
    reader: &mut R,
    buf: &mut Vec<u8>,
    file: Option<&str>,
    line: usize,
) -> Result<usize> {
    buf.clear();
    let read = reader
        .take(MAX_LINE as u64 + 1)
        .read_until(b'\n', buf)
        .map_err(|e| {
            Error::input(
                at(file, Some(line), None),
                format!("cannot read the data: {e}"),
            )
        })?;
    if read != 0 && buf.len() > MAX_LINE && buf.last() != Some(&b'\n') {
        return Err(Error::input(
            at(file, Some(line), None),
            format!("the line is longer than {MAX_LINE} bytes, the most a data row may have"),
        ));
    }
    Ok(read)
}

/// The text of line `line`: valid UTF-8, without a leading byte-order mark (first line)
/// and surrounding blanks; `None` for a blank line or a `#` comment, which are skipped.
pub(super) fn line_text<'b>(
    buf: &'b [u8],
    file: Option<&str>,
    line: usize,
) -> Result<Option<&'b str>> {
    let text = std::str::from_utf8(buf)
        .map_err(|_| Error::input(at(file, Some(line), None), "the line is not valid UTF-8"))?;
    let text = if line == 1 {
        text.trim_start_matches('\u{feff}')
    } else {
        text
    };
    let text = text.trim();
    Ok((!text.is_empty() && !text.starts_with('#')).then_some(text))
}
