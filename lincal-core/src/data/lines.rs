//! The lines of a data file: read one at a time (at most [`MAX_LINE`] bytes), checked as
//! UTF-8, blank lines and `#` comments skipped.

use std::io::BufRead;

use super::cells::at;
use crate::error::{Error, Result};

/// Longest line of a data file, in bytes (a row of 20 joints and a tip is under 1 KiB).
pub const MAX_LINE: usize = 1 << 16;

/// Reads the next line into `buf` (cleared first), never more than [`MAX_LINE`] bytes of
/// it; returns the bytes read, 0 at the end. `line` is the number the line will have.
///
/// A line ends at LF, CRLF or a bare CR (old spreadsheet exports), as in every CSV reader.
pub(crate) fn read_line<R: BufRead>(
    reader: &mut R,
    buf: &mut Vec<u8>,
    file: Option<&str>,
    line: usize,
) -> Result<usize> {
    buf.clear();
    let fail = |e: std::io::Error| {
        Error::input(
            at(file, Some(line), None),
            format!("cannot read the data: {e}"),
        )
    };
    let mut read = 0;
    loop {
        let avail = reader.fill_buf().map_err(fail)?;
        if avail.is_empty() {
            return Ok(read);
        }
        let end = avail.iter().position(|&b| b == b'\n' || b == b'\r');
        let take = end.map_or(avail.len(), |i| i + 1);
        // The content of a line is at most MAX_LINE bytes, its end one more.
        let room = (MAX_LINE + 1).saturating_sub(buf.len());
        buf.extend_from_slice(&avail[..take.min(room)]);
        let cr = end.is_some_and(|i| avail[i] == b'\r');
        reader.consume(take);
        read += take;
        if take > room || (end.is_none() && buf.len() > MAX_LINE) {
            return Err(Error::input(
                at(file, Some(line), None),
                format!("the line is longer than {MAX_LINE} bytes, the most a data row may have"),
            ));
        }
        if end.is_some() {
            // CRLF is one line end: the LF may be the next buffer's first byte.
            if cr && reader.fill_buf().map_err(fail)?.first() == Some(&b'\n') {
                reader.consume(1);
                buf.push(b'\n');
                read += 1;
            }
            return Ok(read);
        }
    }
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

#[cfg(test)]
mod tests {
    use super::read_line;

    fn lines(text: &[u8], cap: usize) -> Vec<String> {
        let mut r = std::io::BufReader::with_capacity(cap, text);
        let mut buf = Vec::new();
        let mut out = Vec::new();
        while read_line(&mut r, &mut buf, None, 1).unwrap() > 0 {
            out.push(String::from_utf8(buf.clone()).unwrap());
        }
        out
    }

    #[test]
    fn ends_lines_at_lf_crlf_and_bare_cr_across_buffer_edges() {
        let text = b"a,b\r\nc\rd\ne";
        for cap in [1, 2, 3, 64] {
            assert_eq!(
                lines(text, cap),
                ["a,b\r\n", "c\r", "d\n", "e"],
                "capacity {cap}"
            );
        }
    }
}
