//! Error chains: how an error that wraps another keeps it and how a chain is printed.
//!
//! The rule (docs in /tmp/arch/H-ERRORS.md, STYLE.md "Errors that say what happened"): a variant
//! that wraps another error keeps it whole as its `#[source]` (or `#[from]`), so
//! [`std::error::Error::source`] walks from what the user asked for down to the library's own
//! error, and a caller matches the cause by its type and variant (`downcast_ref`, `matches!`),
//! never by its text. The variant's message names what failed and where, and ends with the
//! cause's message (`"{what}: {source}"`), so every place that prints an error with `{e}` keeps
//! saying why; [`error_chain`] prints a whole chain and skips a cause whose text the message
//! already holds, so each cause is said once.
//!
//! Entry points: [`Cause`] (a boxed cause for variants fed by several iceoryx2 error types) and
//! [`error_chain`] (the one-line message of an error and its causes).

use std::error::Error;

/// A wrapped library error of one of several types (iceoryx2 gives each operation its own
/// error enum): kept whole, so it can be matched with `downcast_ref::<TheError>()`.
pub type Cause = Box<dyn Error + Send + Sync + 'static>;

/// The one line a user reads for `e`: its message, then `": cause"` for each error down its
/// [`Error::source`] chain whose message the line does not already hold (a variant that prints
/// its cause, or an `#[error(transparent)]` one, is not repeated).
pub fn error_chain(e: &dyn Error) -> String {
    let mut line = e.to_string();
    let mut next = e.source();
    while let Some(cause) = next {
        let text = cause.to_string();
        if !text.is_empty() && !line.contains(&text) {
            line.push_str(": ");
            line.push_str(&text);
        }
        next = cause.source();
    }
    line
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, thiserror::Error)]
    #[error("disk full")]
    struct Root;

    #[derive(Debug, thiserror::Error)]
    enum Mid {
        /// Says its cause.
        #[error("write {path}: {source}")]
        Says { path: String, source: Root },
        /// Leaves its cause to the chain.
        #[error("write {path}")]
        Quiet {
            path: String,
            #[source]
            source: Root,
        },
    }

    #[derive(Debug, thiserror::Error)]
    enum Top {
        #[error(transparent)]
        Through(#[from] Mid),
        #[error("save the model")]
        Save(#[source] Mid),
    }

    #[test]
    fn a_cause_the_message_already_says_is_not_repeated() {
        let e = Top::Through(Mid::Says {
            path: "a.bin".into(),
            source: Root,
        });
        assert_eq!(error_chain(&e), "write a.bin: disk full");
        let e = Top::Save(Mid::Says {
            path: "a.bin".into(),
            source: Root,
        });
        assert_eq!(error_chain(&e), "save the model: write a.bin: disk full");
    }

    #[test]
    fn a_cause_the_message_leaves_out_is_appended_once() {
        let e = Top::Save(Mid::Quiet {
            path: "a.bin".into(),
            source: Root,
        });
        assert_eq!(error_chain(&e), "save the model: write a.bin: disk full");
        let e = Top::Through(Mid::Quiet {
            path: "a.bin".into(),
            source: Root,
        });
        assert_eq!(error_chain(&e), "write a.bin: disk full");
    }
}
