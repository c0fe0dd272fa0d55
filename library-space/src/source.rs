//! Source files and spans: byte ranges mapped to file:line:column and the quoted line.

use serde::{Deserialize, Serialize};

/// A byte range `[start, end)` in one source file.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct Span {
    pub file: u32,
    pub start: u32,
    pub end: u32,
}

impl Span {
    pub fn new(file: u32, start: usize, end: usize) -> Self {
        Span {
            file,
            start: start as u32,
            end: end as u32,
        }
    }
    /// The smallest span covering both (same file assumed).
    pub fn to(self, other: Span) -> Span {
        Span {
            file: self.file,
            start: self.start.min(other.start),
            end: self.end.max(other.end),
        }
    }
}

/// One loaded file: its name as the user gave it (or `std/NAME.rsl` for the standard library)
/// and its text.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct SourceFile {
    pub path: String,
    pub text: String,
    line_starts: Vec<usize>,
}

/// A location resolved for humans: 1-based line and column (in characters).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Location {
    pub file: String,
    pub line: usize,
    pub column: usize,
    /// The whole source line, without its newline.
    pub line_text: String,
    /// Width of the marked range on that line, in characters (≥ 1).
    pub width: usize,
}

impl SourceFile {
    pub fn new(path: String, text: String) -> Self {
        let mut line_starts = vec![0];
        line_starts.extend(text.match_indices('\n').map(|(i, _)| i + 1));
        SourceFile {
            path,
            text,
            line_starts,
        }
    }

    pub fn locate(&self, span: Span) -> Location {
        let start = (span.start as usize).min(self.text.len());
        let line = match self.line_starts.binary_search(&start) {
            Ok(l) => l,
            Err(l) => l - 1,
        };
        let ls = self.line_starts[line];
        let le = self.text[ls..]
            .find('\n')
            .map_or(self.text.len(), |k| ls + k);
        let line_text = self.text[ls..le].trim_end_matches('\r').to_string();
        let column = self.text[ls..start].chars().count() + 1;
        let end = (span.end as usize).clamp(start, le);
        let width = self.text[start..end].chars().count().max(1);
        Location {
            file: self.path.clone(),
            line: line + 1,
            column,
            line_text,
            width,
        }
    }
}

/// All files of a library, indexed by [`Span::file`].
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct SourceMap {
    pub files: Vec<SourceFile>,
}

impl SourceMap {
    pub fn add(&mut self, path: String, text: String) -> u32 {
        self.files.push(SourceFile::new(path, text));
        (self.files.len() - 1) as u32
    }
    pub fn locate(&self, span: Span) -> Location {
        match self.files.get(span.file as usize) {
            Some(f) => f.locate(span),
            None => Location {
                file: "<unknown>".into(),
                line: 0,
                column: 0,
                line_text: String::new(),
                width: 1,
            },
        }
    }
}

/// The most bytes read from one source file: the top-level file of [`crate::Library::load`],
/// each `include`, and so each `"file"` of the query protocol's library ops. The standard
/// library's largest file is about 10 KiB; a library a hundred times the size of the standard
/// library still fits. Reading stops one byte past the cap, so `include "/dev/zero"`-like
/// input costs at most this much memory and time.
pub const MAX_SOURCE_BYTES: u64 = 16 << 20;

/// Reads a library source file, refusing what is not one: anything but a regular file (a
/// directory, a FIFO — whose open would block —, a character or block device such as
/// `/dev/zero`, a socket), a file larger than [`MAX_SOURCE_BYTES`], text that is not UTF-8.
/// The reading is [`robosim_input::read_to_string`], the one reader of every file input. The
/// error is the reason, to follow "cannot read … `path`: ".
pub(crate) fn read_source_file(path: &std::path::Path) -> Result<String, String> {
    robosim_input::read_to_string(
        path,
        "a library source file",
        robosim_input::Limit::fixed(MAX_SOURCE_BYTES),
    )
    .map_err(|e| match e.problem {
        robosim_input::InputProblem::NotRegular(kind) => {
            format!("it is {kind}, not a regular file; a library source must be a file")
        }
        _ => e.reason(),
    })
}
