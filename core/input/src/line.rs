//! Lines of a stream (standard input, a pipe) with a bound on what one line may hold.

use std::io::{self, BufRead};

/// What [`read_line_bounded`] found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Line {
    /// The stream ended before any byte.
    Eof,
    /// A line, in the buffer without its `\n` (the last line of a stream may have none).
    Complete,
    /// The line has more than the limit's bytes before its newline: the buffer holds its first
    /// `limit` bytes, the rest is still unread; [`skip_line`] consumes it.
    TooLong,
}

/// Reads one line into `buf` (cleared first, newline removed), holding at most `max` bytes of
/// it: a longer line stops at `max` bytes and is reported as [`Line::TooLong`], its rest left
/// in the stream, so no input — `/dev/zero` included — makes this buffer more than `max`.
pub fn read_line_bounded<R: BufRead + ?Sized>(
    input: &mut R,
    buf: &mut Vec<u8>,
    max: usize,
) -> io::Result<Line> {
    buf.clear();
    let mut any = false;
    loop {
        let room = max - buf.len();
        // (bytes to consume, the line's end if this chunk ends it)
        let (used, end) = with_chunk(input, |chunk| {
            if chunk.is_empty() {
                return (0, Some(if any { Line::Complete } else { Line::Eof }));
            }
            match chunk.iter().position(|&b| b == b'\n') {
                Some(k) if k <= room => {
                    buf.extend_from_slice(&chunk[..k]);
                    (k + 1, Some(Line::Complete))
                }
                None if chunk.len() <= room => {
                    buf.extend_from_slice(chunk);
                    (chunk.len(), None)
                }
                _ => {
                    // More than `max` bytes before the newline.
                    buf.extend_from_slice(&chunk[..room]);
                    (room, Some(Line::TooLong))
                }
            }
        })?;
        input.consume(used);
        match end {
            Some(line) => return Ok(line),
            None => any = true,
        }
    }
}

/// `f` of the bytes `input.fill_buf()` holds (empty at the end of the stream), the read
/// retried while it is interrupted. (A closure rather than the slice: a borrow returned from
/// the retry loop would hold `input` for every iteration.)
fn with_chunk<R: BufRead + ?Sized, T>(input: &mut R, f: impl FnOnce(&[u8]) -> T) -> io::Result<T> {
    loop {
        match input.fill_buf() {
            Ok(chunk) => return Ok(f(chunk)),
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
}

/// Consumes the stream up to and including the next newline (or to its end), holding nothing;
/// returns the bytes skipped, the newline not counted.
pub fn skip_line<R: BufRead + ?Sized>(input: &mut R) -> io::Result<u64> {
    let mut skipped = 0u64;
    loop {
        // (bytes to consume, whether the line ended: the newline or the end of the stream)
        let (n, newline, ended) = with_chunk(input, |chunk| {
            match chunk.iter().position(|&b| b == b'\n') {
                Some(k) => (k, true, true),
                None => (chunk.len(), false, chunk.is_empty()),
            }
        })?;
        input.consume(n + usize::from(newline));
        skipped += n as u64;
        if ended {
            return Ok(skipped);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lines(input: &[u8], max: usize, cap: usize) -> Vec<(Line, Vec<u8>, u64)> {
        // A tiny BufReader capacity makes every line cross buffer boundaries.
        let mut r = io::BufReader::with_capacity(cap, input);
        let mut out = Vec::new();
        let mut buf = Vec::new();
        loop {
            let l = read_line_bounded(&mut r, &mut buf, max).expect("read");
            let skipped = if l == Line::TooLong {
                skip_line(&mut r).expect("skip")
            } else {
                0
            };
            if l == Line::Eof {
                return out;
            }
            out.push((l, buf.clone(), skipped));
        }
    }

    #[test]
    fn lines_at_the_limit_are_whole_and_longer_ones_are_cut_and_skipped() {
        for cap in [1, 2, 3, 5, 64] {
            let got = lines(b"abc\nabcd\nabcde\n\nxy", 4, cap);
            assert_eq!(
                got,
                vec![
                    (Line::Complete, b"abc".to_vec(), 0),
                    (Line::Complete, b"abcd".to_vec(), 0),
                    (Line::TooLong, b"abcd".to_vec(), 1),
                    (Line::Complete, b"".to_vec(), 0),
                    (Line::Complete, b"xy".to_vec(), 0),
                ],
                "buffer capacity {cap}"
            );
        }
    }

    #[test]
    fn an_endless_line_holds_at_most_the_limit() {
        // An unending stream of zero bytes (like /dev/zero): the read stops at the limit.
        let mut zeros = io::BufReader::new(io::repeat(0));
        let mut buf = Vec::new();
        let l = read_line_bounded(&mut zeros, &mut buf, 1000).expect("read");
        assert_eq!(l, Line::TooLong);
        assert_eq!(buf.len(), 1000);
        assert!(buf.capacity() < 64 << 10, "{}", buf.capacity());
    }
}
