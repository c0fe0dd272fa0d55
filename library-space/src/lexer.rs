//! The lexer: identifiers, numbers, strings, punctuation; `//` and `/* */` comments. Newlines
//! carry no meaning.

use crate::error::{ErrorKind, RResult, RawError};
use crate::source::Span;

#[derive(Debug, Clone, PartialEq)]
pub enum Tok {
    Ident(String),
    Number(f64),
    Str(String),
    /// One of `( ) { } [ ] , : ; = + - * / ^`.
    Punct(char),
    Eof,
}

impl Tok {
    pub fn describe(&self) -> String {
        match self {
            Tok::Ident(s) => format!("name `{s}`"),
            Tok::Number(n) => format!("number `{n}`"),
            Tok::Str(s) => format!("string \"{s}\""),
            Tok::Punct(c) => format!("`{c}`"),
            Tok::Eof => "end of file".into(),
        }
    }
}

#[derive(Debug, Clone)]
pub struct Token {
    pub tok: Tok,
    pub span: Span,
    /// `//` comment lines directly above this token (used as declaration docs).
    pub doc: Option<String>,
}

pub fn lex(file: u32, text: &str) -> RResult<Vec<Token>> {
    let b = text.as_bytes();
    let mut i = 0;
    let mut out = Vec::new();
    let mut doc: Vec<String> = Vec::new();
    while i < b.len() {
        let c = b[i];
        if c == b'\n' {
            // a blank (or whitespace-only) line separates a comment from what follows
            let line_start = text[..i].rfind('\n').map_or(0, |k| k + 1);
            if i > 0 && text[line_start..i].trim().is_empty() && line_start > 0 {
                doc.clear();
            }
            i += 1;
            continue;
        }
        if c.is_ascii_whitespace() {
            i += 1;
            continue;
        }
        if c == b'/' && b.get(i + 1) == Some(&b'/') {
            let end = text[i..].find('\n').map_or(b.len(), |k| i + k);
            doc.push(text[i + 2..end].trim().to_string());
            i = end;
            continue;
        }
        if c == b'/' && b.get(i + 1) == Some(&b'*') {
            match text[i + 2..].find("*/") {
                Some(k) => i = i + 2 + k + 2,
                None => {
                    return Err(RawError::new(
                        ErrorKind::Syntax,
                        Span::new(file, i, i + 2),
                        "unterminated block comment",
                    )
                    .expected("`*/` to close the comment opened here"));
                }
            }
            continue;
        }
        let start = i;
        let tok = if c.is_ascii_alphabetic() || c == b'_' {
            while i < b.len() && (b[i].is_ascii_alphanumeric() || b[i] == b'_') {
                i += 1;
            }
            Tok::Ident(text[start..i].to_string())
        } else if c.is_ascii_digit() || (c == b'.' && b.get(i + 1).is_some_and(u8::is_ascii_digit))
        {
            while i < b.len() && (b[i].is_ascii_digit() || b[i] == b'.') {
                i += 1;
            }
            // exponent: 1e-3, 2.5E6 (but not `2 e`, and `3 m` is a unit)
            if i < b.len() && (b[i] == b'e' || b[i] == b'E') {
                let mut j = i + 1;
                if j < b.len() && (b[j] == b'+' || b[j] == b'-') {
                    j += 1;
                }
                if j < b.len() && b[j].is_ascii_digit() {
                    while j < b.len() && b[j].is_ascii_digit() {
                        j += 1;
                    }
                    i = j;
                }
            }
            let s = &text[start..i];
            match s.parse::<f64>() {
                Ok(v) => Tok::Number(v),
                Err(_) => {
                    return Err(RawError::new(
                        ErrorKind::Syntax,
                        Span::new(file, start, i),
                        format!("malformed number `{s}`"),
                    )
                    .expected("a number such as 12, 0.5 or 1.5e-3"));
                }
            }
        } else if c == b'"' {
            i += 1;
            while i < b.len() && b[i] != b'"' && b[i] != b'\n' {
                i += 1;
            }
            if i >= b.len() || b[i] != b'"' {
                return Err(RawError::new(
                    ErrorKind::Syntax,
                    Span::new(file, start, i),
                    "unterminated string",
                )
                .expected("a closing `\"` on the same line"));
            }
            i += 1;
            Tok::Str(text[start + 1..i - 1].to_string())
        } else if "(){}[],:;=+-*/^".as_bytes().contains(&c) {
            i += 1;
            Tok::Punct(c as char)
        } else {
            let ch = text[i..].chars().next().unwrap_or('?');
            let hint = match ch {
                '×' | '·' => " (write `*` for multiplication)",
                '÷' => " (write `/` for division)",
                '−' => " (write `-` for minus)",
                _ => "",
            };
            return Err(RawError::new(
                ErrorKind::Syntax,
                Span::new(file, i, i + ch.len_utf8()),
                format!("unexpected character `{ch}`{hint}"),
            )
            .expected(
                "a name, a number, a string, an operator (+ - * / ^) or one of ( ) { } [ ] , : = ;",
            ));
        };
        let d = if doc.is_empty() {
            None
        } else {
            Some(doc.join("\n"))
        };
        doc.clear();
        out.push(Token {
            tok,
            span: Span::new(file, start, i),
            doc: d,
        });
    }
    out.push(Token {
        tok: Tok::Eof,
        span: Span::new(file, b.len(), b.len()),
        doc: None,
    });
    Ok(out)
}
