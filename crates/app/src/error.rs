//! What the operations' error enums share: an internal `anyhow::Error` keeps its kind when it
//! is a config or output error as it was raised, else it is the enum's `Other`.

/// An internal error by its kind: a config or output error as it was raised (no context
/// wrapped it), or anything else.
pub(crate) enum Kind {
    Config(platoon_config::ConfigError),
    Output(platoon_output::error::OutputError),
    Other(anyhow::Error),
}

impl From<anyhow::Error> for Kind {
    fn from(e: anyhow::Error) -> Self {
        let outermost = e.chain().next();
        if outermost.is_some_and(|c| c.is::<platoon_config::ConfigError>()) {
            return Self::Config(e.downcast().expect("checked"));
        }
        if outermost.is_some_and(|c| c.is::<platoon_output::error::OutputError>()) {
            return Self::Output(e.downcast().expect("checked"));
        }
        Self::Other(e)
    }
}

/// `From<anyhow::Error>` (by [`Kind`]), and `From` the errors of JSON, CSV and I/O (`Other`), for an operation's error enum with `Config`, `Output` and `Other` variants.
macro_rules! operation_error {
    ($error:ident) => {
        impl From<anyhow::Error> for $error {
            /// Its kind when it is a config or output error as it was raised; with a context
            /// (words that the message keeps) it stays `Other`.
            fn from(e: anyhow::Error) -> Self {
                match crate::error::Kind::from(e) {
                    crate::error::Kind::Config(c) => Self::Config(c),
                    crate::error::Kind::Output(o) => Self::Output(o),
                    crate::error::Kind::Other(e) => Self::Other(e),
                }
            }
        }

        impl From<serde_json::Error> for $error {
            fn from(e: serde_json::Error) -> Self {
                Self::Other(e.into())
            }
        }

        impl From<std::io::Error> for $error {
            fn from(e: std::io::Error) -> Self {
                Self::Other(e.into())
            }
        }

        impl From<csv::Error> for $error {
            fn from(e: csv::Error) -> Self {
                Self::Other(e.into())
            }
        }
    };
}
