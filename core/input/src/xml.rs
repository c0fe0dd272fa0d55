//! The nesting depth of XML text, measured without recursion, before a recursive parser sees
//! it. roxmltree (URDF, Collada) parses an element's content by recursing into each child
//! element and has no depth option: twenty thousand nested elements overflow the stack and
//! abort the process — in a query server, for every later request too.

/// The deepest element nesting read from XML (URDF and Collada). A URDF nests four deep
/// (`robot/link/visual/geometry/mesh`); Collada's scene graph is the deep one, and its
/// `<node>`s are refused past 256 levels anyway. roxmltree uses well under 1 KiB of stack per
/// level, so this many levels fit in any thread's stack.
pub const MAX_XML_DEPTH: usize = 512;

/// XML nested deeper than the limit (the message leaves the line to the caller's error, which
/// names the file too).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("elements nested more than {limit} deep{}", via_entities(*through_entities))]
pub struct XmlTooDeep {
    pub limit: usize,
    /// 1-based line of the first element past the limit (of the document's last line when the
    /// depth is reached only through entity references).
    pub line: u32,
    /// The depth is reached only by expanding entities declared in the DOCTYPE.
    pub through_entities: bool,
}

fn via_entities(through: bool) -> &'static str {
    if through {
        ", counting the elements its DOCTYPE's entities expand to"
    } else {
        ""
    }
}

/// How deep roxmltree lets entity references nest (`&a;` whose text holds `&b;` …).
const ENTITY_NESTING: usize = 10;

/// Checks that `text`'s elements nest at most `limit` deep, counting what entity references
/// could add: an entity's replacement text may hold elements, and roxmltree expands references
/// up to ten levels, so the bound is the document's depth plus ten times the deepest entity
/// text (an over-estimate only for files whose entities hold elements, which URDF and Collada
/// files do not). Malformed XML is not judged here: the parser reports it.
pub fn xml_depth(text: &str, limit: usize) -> Result<(), XmlTooDeep> {
    let bytes = text.as_bytes();
    let mut entity_depth = 0usize;
    let document = scan(bytes, limit, Some(&mut entity_depth)).map_err(|at| XmlTooDeep {
        limit,
        line: line_of(bytes, at),
        through_entities: false,
    })?;
    if document.saturating_add(entity_depth.saturating_mul(ENTITY_NESTING)) > limit {
        return Err(XmlTooDeep {
            limit,
            line: line_of(bytes, bytes.len()),
            through_entities: true,
        });
    }
    Ok(())
}

fn line_of(bytes: &[u8], at: usize) -> u32 {
    let n = bytes[..at.min(bytes.len())]
        .iter()
        .filter(|&&b| b == b'\n')
        .count();
    u32::try_from(n + 1).unwrap_or(u32::MAX)
}

fn find(bytes: &[u8], from: usize, needle: &[u8]) -> Option<usize> {
    bytes
        .get(from..)?
        .windows(needle.len())
        .position(|w| w == needle)
        .map(|k| from + k)
}

/// The deepest nesting of `bytes`, or the offset of the first element past `limit`. With
/// `entities`, a DOCTYPE's quoted entity texts are measured too (their deepest nesting is
/// stored there); without, a DOCTYPE is skipped.
fn scan(bytes: &[u8], limit: usize, mut entities: Option<&mut usize>) -> Result<usize, usize> {
    let n = bytes.len();
    let (mut depth, mut deepest) = (0usize, 0usize);
    let mut i = 0;
    while let Some(k) = bytes[i..].iter().position(|&b| b == b'<') {
        let at = i + k;
        let rest = &bytes[at..];
        i = if rest.starts_with(b"<!--") {
            find(bytes, at + 4, b"-->").map_or(n, |e| e + 3)
        } else if rest.starts_with(b"<![CDATA[") {
            find(bytes, at + 9, b"]]>").map_or(n, |e| e + 3)
        } else if rest.starts_with(b"<?") {
            find(bytes, at + 2, b"?>").map_or(n, |e| e + 2)
        } else if rest.starts_with(b"<!") {
            doctype_end(bytes, at, limit, entities.as_deref_mut())
        } else if rest.starts_with(b"</") {
            depth = depth.saturating_sub(1);
            bytes[at..]
                .iter()
                .position(|&b| b == b'>')
                .map_or(n, |e| at + e + 1)
        } else {
            let (end, empty) = tag_end(bytes, at);
            if depth + 1 > limit {
                return Err(at);
            }
            deepest = deepest.max(depth + 1);
            if !empty {
                depth += 1;
            }
            end
        };
        if i >= n {
            break;
        }
    }
    Ok(deepest)
}

/// The end of a start tag beginning at `at` (quotes respected), and whether it is empty
/// (`<a/>`).
fn tag_end(bytes: &[u8], at: usize) -> (usize, bool) {
    let mut quote = None;
    for (k, &b) in bytes.iter().enumerate().skip(at + 1) {
        match quote {
            Some(q) if b == q => quote = None,
            Some(_) => {}
            None if b == b'"' || b == b'\'' => quote = Some(b),
            None if b == b'>' => return (k + 1, bytes[k - 1] == b'/'),
            None => {}
        }
    }
    (bytes.len(), false)
}

/// The end of a `<!…>` declaration (a DOCTYPE with its internal subset in brackets), measuring
/// each quoted text in it as entity replacement text when `entities` is given.
fn doctype_end(bytes: &[u8], at: usize, limit: usize, entities: Option<&mut usize>) -> usize {
    let mut quote: Option<(u8, usize)> = None;
    let mut brackets = 0usize;
    let mut deepest = 0usize;
    let mut k = at + 2;
    while k < bytes.len() {
        let b = bytes[k];
        match quote {
            Some((q, start)) if b == q => {
                if entities.is_some() {
                    // Entity texts are measured without entities of their own.
                    let d = scan(&bytes[start..k], limit, None).unwrap_or(limit + 1);
                    deepest = deepest.max(d);
                }
                quote = None;
            }
            Some(_) => {}
            None => match b {
                b'"' | b'\'' => quote = Some((b, k + 1)),
                b'[' => brackets += 1,
                b']' => brackets = brackets.saturating_sub(1),
                b'<' if bytes[k..].starts_with(b"<!--") => {
                    k = find(bytes, k + 4, b"-->").map_or(bytes.len(), |e| e + 2);
                }
                b'>' if brackets == 0 => {
                    if let Some(e) = entities {
                        *e = (*e).max(deepest);
                    }
                    return k + 1;
                }
                _ => {}
            },
        }
        k += 1;
    }
    if let Some(e) = entities {
        *e = (*e).max(deepest);
    }
    bytes.len()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn nested(n: usize) -> String {
        format!("{}{}", "<a x=\"/>\">".repeat(n), "</a>".repeat(n))
    }

    #[test]
    fn depth_counts_elements_not_markup() {
        let ok = "<?xml version=\"1.0\"?><!-- <a><a><a> --><r><![CDATA[<a><a><a>]]><b/><c a='<d>'><e/></c></r>";
        assert!(xml_depth(ok, 3).is_ok());
        assert!(xml_depth(ok, 2).is_err());
        assert!(xml_depth(&nested(512), 512).is_ok());
        let e = xml_depth(&format!("<r>\n{}</r>", nested(600)), 512).expect_err("too deep");
        assert_eq!(
            e,
            XmlTooDeep {
                limit: 512,
                line: 2,
                through_entities: false
            }
        );
        assert_eq!(e.to_string(), "elements nested more than 512 deep");
    }

    #[test]
    fn entity_texts_count_ten_times() {
        let doc = |inner: usize, outer: usize| {
            format!(
                "<!DOCTYPE r [ <!ENTITY e \"{}\"> ]>\n{}&e;{}",
                nested(inner).replace('"', "'"),
                "<r>".repeat(outer),
                "</r>".repeat(outer)
            )
        };
        assert!(xml_depth(&doc(1, 1), 11).is_ok());
        assert!(xml_depth(&doc(50, 10), 512).is_ok());
        let e = xml_depth(&doc(51, 10), 512).expect_err("through entities");
        assert!(e.through_entities);
    }
}
