//! Size limits per input format, each with a documented default and an environment variable
//! that raises (or lowers) it.

/// The most bytes one input may have: `default`, unless the environment variable `env` (when
/// there is one) gives another size. The variable takes a byte count, optionally followed by
/// `K`, `M` or `G` (binary: `64M` = 64 MiB), and is read on every use.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Limit {
    /// Bytes, when the variable is unset.
    pub default: u64,
    /// The environment variable that overrides it (`None`: fixed).
    pub env: Option<&'static str>,
}

/// An environment variable that does not hold a size.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{var}={value:?} is not a size (a byte count, optionally followed by K, M or G)")]
pub struct LimitError {
    pub var: &'static str,
    pub value: String,
}

impl Limit {
    /// Text formats: URDF, link files, editor scripts and ROBOSIM programs, fault models,
    /// effects files (16 MiB; `ROBOSIM_MAX_TEXT_BYTES`). The largest shipped URDF is tens of
    /// KiB.
    pub const TEXT: Limit = Limit {
        default: 16 << 20,
        env: Some("ROBOSIM_MAX_TEXT_BYTES"),
    };
    /// Mesh files: STL, OBJ, Collada (256 MiB; `ROBOSIM_MAX_MESH_BYTES`): a binary STL of
    /// about five million triangles.
    pub const MESH: Limit = Limit {
        default: 256 << 20,
        env: Some("ROBOSIM_MAX_MESH_BYTES"),
    };
    /// Model files (binary and JSON) and trajectory logs (1 GiB; `ROBOSIM_MAX_MODEL_BYTES`):
    /// data the program wrote itself, which grows with the scene or the run.
    pub const MODEL: Limit = Limit {
        default: 1 << 30,
        env: Some("ROBOSIM_MAX_MODEL_BYTES"),
    };
    /// One request line of `robosim query` (64 MiB; `ROBOSIM_MAX_LINE_BYTES`).
    pub const LINE: Limit = Limit {
        default: 64 << 20,
        env: Some("ROBOSIM_MAX_LINE_BYTES"),
    };

    /// A limit no variable changes.
    pub const fn fixed(bytes: u64) -> Limit {
        Limit {
            default: bytes,
            env: None,
        }
    }

    /// The limit in force: the variable's size when it is set, else the default.
    pub fn bytes(&self) -> Result<u64, LimitError> {
        let Some(var) = self.env else {
            return Ok(self.default);
        };
        match std::env::var(var) {
            Ok(value) => parse_size(&value).ok_or(LimitError { var, value }),
            Err(std::env::VarError::NotPresent) => Ok(self.default),
            Err(std::env::VarError::NotUnicode(v)) => Err(LimitError {
                var,
                value: v.to_string_lossy().into_owned(),
            }),
        }
    }
}

/// `123`, `64K`, `16M`, `2G` (binary multiples; a trailing `iB`/`B` is allowed: `16MiB`).
fn parse_size(s: &str) -> Option<u64> {
    let s = s.trim();
    let s = s
        .strip_suffix("iB")
        .or_else(|| s.strip_suffix('B'))
        .unwrap_or(s);
    let (digits, shift) = match s.as_bytes().last()? {
        b'K' | b'k' => (&s[..s.len() - 1], 10),
        b'M' | b'm' => (&s[..s.len() - 1], 20),
        b'G' | b'g' => (&s[..s.len() - 1], 30),
        _ => (s, 0),
    };
    let n: u64 = digits.trim().parse().ok()?;
    n.checked_mul(1u64 << shift)
}

/// A size for a message: `16 MiB`, `512 KiB`, `1000 bytes` (exact: a whole number of the
/// largest unit that divides it).
pub fn format_bytes(n: u64) -> String {
    const UNITS: [(u64, &str); 3] = [(1 << 30, "GiB"), (1 << 20, "MiB"), (1 << 10, "KiB")];
    for (size, unit) in UNITS {
        if n >= size && n.is_multiple_of(size) {
            return format!("{} {unit}", n / size);
        }
    }
    if n == 1 {
        "1 byte".to_owned()
    } else {
        format!("{n} bytes")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_parse_with_binary_suffixes() {
        assert_eq!(parse_size("123"), Some(123));
        assert_eq!(parse_size("64K"), Some(64 << 10));
        assert_eq!(parse_size("16M"), Some(16 << 20));
        assert_eq!(parse_size("16MiB"), Some(16 << 20));
        assert_eq!(parse_size("2g"), Some(2 << 30));
        assert_eq!(parse_size("x"), None);
        assert_eq!(parse_size(""), None);
        assert_eq!(parse_size("-1"), None);
        assert_eq!(parse_size("99999999999999G"), None);
    }

    #[test]
    fn sizes_print_exactly() {
        assert_eq!(format_bytes(16 << 20), "16 MiB");
        assert_eq!(format_bytes(1 << 30), "1 GiB");
        assert_eq!(format_bytes(1536), "1536 bytes");
        assert_eq!(format_bytes(2048), "2 KiB");
        assert_eq!(format_bytes(1000), "1000 bytes");
        assert_eq!(format_bytes(1), "1 byte");
    }
}
