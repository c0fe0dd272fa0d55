//! What a report or bench run says around its work: a spinner while it runs ([`spun`]) and, at
//! the end, where its files went ([`wrote`]). The `robosim` binary prints the text; nothing
//! here writes to standard output (the spinner draws on standard error, [`crate::progress`]).
//!
//! Entry points: [`spun`], [`wrote`].

use std::path::{Path, PathBuf};

/// Runs `work` under a spinner named `what` ("bench ipc", "report ik"), cleared when it ends
/// (also when it fails); `work`'s answer unchanged.
pub fn spun<T, E>(what: &str, work: impl FnOnce() -> Result<T, E>) -> Result<T, E> {
    let pb = crate::progress::spinner(what);
    let r = work();
    pb.finish_and_clear();
    r
}

/// Where the files of a report or bench went, one line each (`wrote PATH`): the `paths` it
/// returned, or else the directory `out` (`wrote into DIR`); absolute, so a relative `--out`
/// cannot surprise (a path that cannot be resolved is said as given).
pub fn wrote(out: &Path, paths: &[PathBuf]) -> String {
    let mut text = String::new();
    if paths.is_empty() {
        let abs = std::fs::canonicalize(out).unwrap_or_else(|_| out.to_owned());
        text.push_str(&format!("wrote into {}\n", abs.display()));
    }
    for p in paths {
        let abs = std::fs::canonicalize(p).unwrap_or_else(|_| p.clone());
        text.push_str(&format!("wrote {}\n", abs.display()));
    }
    text
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wrote_names_each_file_or_else_the_directory() {
        let dir = tempfile::tempdir().expect("a temporary directory");
        let abs = std::fs::canonicalize(dir.path()).expect("the directory resolves");
        assert_eq!(
            wrote(dir.path(), &[]),
            format!("wrote into {}\n", abs.display())
        );
        let f = dir.path().join("a.csv");
        std::fs::write(&f, "x").expect("a file");
        let missing = PathBuf::from("no/such/file.md");
        assert_eq!(
            wrote(dir.path(), &[f, missing]),
            format!(
                "wrote {}\nwrote no/such/file.md\n",
                abs.join("a.csv").display()
            )
        );
    }

    #[test]
    fn spun_answers_what_the_work_answers() {
        assert_eq!(spun("test ok", || Ok::<_, String>(3)), Ok(3));
        assert_eq!(
            spun("test err", || Err::<u8, _>("failed".to_owned())),
            Err("failed".to_owned())
        );
    }
}
