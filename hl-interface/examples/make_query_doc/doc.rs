//! The example blocks of docs/query.md: how they are written (the `make_query_doc` example)
//! and read back and compared with a fresh run (the root package's `tests/query_docs.rs`,
//! which includes this file), so both sides use one cutting rule and one block format.
//!
//! A block is
//!
//! ````text
//! #### `op`            (or: #### error `kind`, when the answer is a refusal)
//!
//! ```
//! REQUEST LINE         (the request file's line, byte for byte)
//! ANSWER LINE          (cut after LIMIT characters: PREFIX …  [cut here: N more characters])
//! ```
//! ````
//!
//! Entry points: [`render`] and [`replace`] (writing), [`parse`] and [`compare`] (checking).

use serde_json::Value;
use std::fmt;

/// Answers longer than this many characters (Unicode scalar values) are cut.
pub const LIMIT: usize = 900;

/// A pair of marker lines around a generated block in docs/query.md.
#[derive(Debug, Clone, Copy)]
pub struct Markers {
    pub begin: &'static str,
    pub end: &'static str,
}

/// The pure ops' examples (hl-interface/examples/requests.jsonl, no session).
pub const PURE: Markers = Markers {
    begin: "<!-- examples:begin -->",
    end: "<!-- examples:end -->",
};

/// The session ops' examples (hl-interface/examples/session_requests.jsonl on a fresh
/// `robosim up surgical_positioner_cell`).
pub const SESSION: Markers = Markers {
    begin: "<!-- session-examples:begin -->",
    end: "<!-- session-examples:end -->",
};

/// Relative tolerance on a number of a documented answer against a fresh run...
pub const REL_TOL: f64 = 1e-9;
/// ... or this absolute one, for values that are rounding noise around zero (1e-17).
pub const ABS_TOL: f64 = 1e-12;

const CUT_OPEN: &str = " …  [cut here: ";
const CUT_CLOSE: &str = " more characters]";

/// Why docs/query.md could not be read or rewritten, or a documented answer is not what a run
/// gives.
#[derive(Debug, Clone, PartialEq)]
pub struct DocError(pub String);

impl fmt::Display for DocError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for DocError {}

/// An answer as the doc shows it.
#[derive(Debug, Clone, PartialEq)]
pub enum Shown {
    Whole(String),
    /// The first [`LIMIT`] characters and how many were left out.
    Cut {
        prefix: String,
        more: usize,
    },
}

impl Shown {
    /// `answer` after the cutting rule.
    pub fn of(answer: &str) -> Shown {
        let n = answer.chars().count();
        if n <= LIMIT {
            return Shown::Whole(answer.to_owned());
        }
        Shown::Cut {
            prefix: answer.chars().take(LIMIT).collect(),
            more: n - LIMIT,
        }
    }

    fn line(&self) -> String {
        match self {
            Shown::Whole(a) => a.clone(),
            Shown::Cut { prefix, more } => format!("{prefix}{CUT_OPEN}{more}{CUT_CLOSE}"),
        }
    }

    fn from_line(line: &str) -> Result<Shown, DocError> {
        let Some(body) = line.strip_suffix(CUT_CLOSE) else {
            return Ok(Shown::Whole(line.to_owned()));
        };
        let (prefix, more) = body
            .rsplit_once(CUT_OPEN)
            .ok_or_else(|| DocError(format!("a cut answer without its cut mark: {line}")))?;
        let more = more
            .parse()
            .map_err(|_| DocError(format!("cut mark: {more:?} is not a count")))?;
        Ok(Shown::Cut {
            prefix: prefix.to_owned(),
            more,
        })
    }
}

/// One documented example: the request line and the answer as shown.
#[derive(Debug, Clone, PartialEq)]
pub struct Example {
    pub title: String,
    pub request: String,
    pub answer: Shown,
}

/// The heading of an example: the request's op when answered, the error kind when refused.
pub fn title(request: &str, answer: &str) -> String {
    let a: Value = serde_json::from_str(answer).unwrap_or(Value::Null);
    if a["ok"] == true {
        let r: Value = serde_json::from_str(request).unwrap_or(Value::Null);
        format!("`{}`", r["op"].as_str().unwrap_or("?"))
    } else {
        format!("error `{}`", a["error"]["kind"].as_str().unwrap_or("?"))
    }
}

/// The text between a pair of markers for these (request line, answer line) pairs.
pub fn render(pairs: &[(String, String)]) -> String {
    let blocks: Vec<String> = pairs
        .iter()
        .map(|(req, ans)| {
            format!(
                "#### {}\n\n```\n{req}\n{}\n```\n",
                title(req, ans),
                Shown::of(ans).line()
            )
        })
        .collect();
    format!("\n{}", blocks.join("\n"))
}

/// The text between `m`'s markers in `doc`.
fn between(doc: &str, m: Markers) -> Result<(&str, &str, &str), DocError> {
    let missing = |what: &str| DocError(format!("docs/query.md: no marker line {what}"));
    let (head, rest) = doc.split_once(m.begin).ok_or_else(|| missing(m.begin))?;
    let (body, tail) = rest.split_once(m.end).ok_or_else(|| missing(m.end))?;
    Ok((head, body, tail))
}

/// `doc` with the text between `m`'s markers replaced by `body`.
pub fn replace(doc: &str, m: Markers, body: &str) -> Result<String, DocError> {
    let (head, _, tail) = between(doc, m)?;
    Ok(format!("{head}{}{body}{}{tail}", m.begin, m.end))
}

/// The examples between `m`'s markers, in order.
pub fn parse(doc: &str, m: Markers) -> Result<Vec<Example>, DocError> {
    let (_, body, _) = between(doc, m)?;
    let mut out = Vec::new();
    let mut lines = body.lines();
    while let Some(line) = lines.next() {
        let Some(title) = line.strip_prefix("#### ") else {
            continue;
        };
        let mut next = || {
            lines
                .next()
                .ok_or_else(|| DocError(format!("example {title}: the block ends early")))
        };
        let (blank, open, request, answer, close) = (next()?, next()?, next()?, next()?, next()?);
        if !(blank.is_empty() && open == "```" && close == "```") {
            return Err(DocError(format!(
                "example {title}: expected an empty line, ``` , request, answer, ```"
            )));
        }
        out.push(Example {
            title: title.to_owned(),
            request: request.to_owned(),
            answer: Shown::from_line(answer)?,
        });
    }
    Ok(out)
}

/// A piece of an answer line: a number outside strings, or the text between numbers.
#[derive(Debug, Clone, PartialEq)]
enum Token<'a> {
    Number(&'a str),
    Text(&'a str),
}

/// Splits JSON text (possibly cut anywhere) into numbers and the text between them.
fn tokens(s: &str) -> Vec<Token<'_>> {
    let b = s.as_bytes();
    let mut out = Vec::new();
    let (mut i, mut text_from) = (0, 0);
    let mut in_string = false;
    while i < b.len() {
        let c = b[i];
        if in_string {
            match c {
                b'\\' => i += 1,
                b'"' => in_string = false,
                _ => {}
            }
            i += 1;
        } else if c == b'"' {
            in_string = true;
            i += 1;
        } else if c == b'-' || c.is_ascii_digit() {
            if text_from < i {
                out.push(Token::Text(&s[text_from..i]));
            }
            let from = i;
            i += 1;
            while i < b.len() && matches!(b[i], b'0'..=b'9' | b'.' | b'e' | b'E' | b'+' | b'-') {
                i += 1;
            }
            out.push(Token::Number(&s[from..i]));
            text_from = i;
        } else {
            i += 1;
        }
    }
    if text_from < b.len() {
        out.push(Token::Text(&s[text_from..]));
    }
    out
}

/// Whether two number tokens agree to [`REL_TOL`] (or [`ABS_TOL`]).
fn close(a: &str, b: &str) -> bool {
    match (a.parse::<f64>(), b.parse::<f64>()) {
        (Ok(x), Ok(y)) => {
            let d = (x - y).abs();
            d <= ABS_TOL || d <= REL_TOL * x.abs().max(y.abs())
        }
        _ => a == b,
    }
}

/// Compares token streams; `shown` may stop early (a cut), `whole` says it must not.
fn same_tokens(shown: &[Token<'_>], got: &[Token<'_>], whole: bool) -> Result<(), String> {
    if whole && shown.len() != got.len() {
        return Err(format!(
            "{} pieces documented, {} in the answer",
            shown.len(),
            got.len()
        ));
    }
    for (k, (s, g)) in shown.iter().zip(got).enumerate() {
        let ok = match (s, g) {
            (Token::Number(a), Token::Number(b)) => close(a, b),
            (Token::Text(a), Token::Text(b)) => a == b,
            _ => false,
        };
        if !ok {
            return Err(format!("piece {k}: documented {s:?}, answered {g:?}"));
        }
    }
    if shown.len() > got.len() {
        return Err("the documented answer is longer than the answer".to_owned());
    }
    Ok(())
}

/// Whether a fresh `answer` is what `shown` documents: the same text with every number equal
/// to [`REL_TOL`] relative (or [`ABS_TOL`] absolute), so floating-point noise of another
/// machine's maths library does not fail it. A cut answer: its shown prefix likewise (but for
/// the piece the cut fell in), and the count of characters left out exactly when the prefix
/// is byte-equal (else within 10 %: numbers of other last digits print with other lengths).
pub fn compare(shown: &Shown, answer: &str) -> Result<(), String> {
    match shown {
        Shown::Whole(doc) => same_tokens(&tokens(doc), &tokens(answer), true),
        Shown::Cut { prefix, more } => {
            let n = answer.chars().count();
            let Some(rest) = n.checked_sub(LIMIT).filter(|r| *r > 0) else {
                return Err(format!(
                    "documented as cut, but the answer has only {n} characters"
                ));
            };
            if Shown::of(answer) == *shown {
                return Ok(());
            }
            let mut shown_tokens = tokens(prefix);
            shown_tokens.pop();
            same_tokens(&shown_tokens, &tokens(answer), false)?;
            if rest.abs_diff(*more) * 10 > rest {
                return Err(format!(
                    "documented {more} characters after the cut, the answer has {rest}"
                ));
            }
            Ok(())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_long_answer_is_cut_and_read_back() {
        let long = format!("{{\"x\":[{}]}}", vec!["1.25"; 400].join(","));
        let shown = Shown::of(&long);
        let Shown::Cut { prefix, more } = &shown else {
            panic!("not cut")
        };
        assert_eq!(prefix.chars().count(), LIMIT);
        assert_eq!(*more, long.len() - LIMIT);
        assert_eq!(Shown::from_line(&shown.line()), Ok(shown.clone()));
        assert_eq!(compare(&shown, &long), Ok(()));
        let other = long.replacen("1.25", "1.5", 1);
        assert!(compare(&shown, &other).is_err());
        // Last-digit noise in the shown part, and the count after the cut a little off.
        let noisy = long.replacen("1.25", "1.2500000000000002", 2);
        assert_ne!(Shown::of(&noisy), shown);
        assert_eq!(compare(&shown, &noisy), Ok(()));
        let shorter = format!("{{\"x\":[{}]}}", vec!["1.25"; 200].join(","));
        assert!(
            compare(&shown, &shorter).is_err(),
            "far fewer characters after the cut"
        );
    }

    #[test]
    fn numbers_compare_to_a_tolerance_and_text_exactly() {
        let doc = Shown::Whole(r#"{"a":1.0000000000000002,"b":1e-17,"s":"x1"}"#.to_owned());
        assert_eq!(compare(&doc, r#"{"a":1.0,"b":-3e-18,"s":"x1"}"#), Ok(()));
        assert!(compare(&doc, r#"{"a":1.001,"b":0,"s":"x1"}"#).is_err());
        assert!(compare(&doc, r#"{"a":1.0,"b":0,"s":"x2"}"#).is_err());
        assert!(compare(&doc, r#"{"a":1.0,"b":0,"s":"x1","c":2}"#).is_err());
    }

    #[test]
    fn blocks_round_trip() {
        let pairs = vec![
            (
                r#"{"id": 1, "op": "fk"}"#.to_owned(),
                r#"{"id":1,"ok":true,"pose":[]}"#.to_owned(),
            ),
            (
                "[1]".to_owned(),
                r#"{"id":null,"ok":false,"error":{"kind":"bad_request","message":"m"}}"#.to_owned(),
            ),
        ];
        let doc = format!("a\n{}\n{}\nb\n", PURE.begin, PURE.end);
        let doc = replace(&doc, PURE, &render(&pairs)).expect("markers");
        let back = parse(&doc, PURE).expect("parse");
        assert_eq!(back.len(), 2);
        assert_eq!(back[0].title, "`fk`");
        assert_eq!(back[1].title, "error `bad_request`");
        assert_eq!(back[1].request, "[1]");
        assert!(parse(&doc, SESSION).is_err(), "no session markers");
    }
}
