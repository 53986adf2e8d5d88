//! What the operations' error enums share: [`OtherError`], the `Other` of each (what no caller
//! branches on, said in words that name the file, process or step, with its cause), the
//! [`Context`] that makes one, and the conversions every enum has.
use std::fmt::Display;

/// Any error, boxed: the cause a [`OtherError`] keeps.
pub type BoxError = Box<dyn std::error::Error + Send + Sync + 'static>;

/// A failure no caller branches on: an error in words (the file, the process or the step it
/// is about) with its cause, or a cause as it was raised. Its message is its own; `{:#}` of
/// an `anyhow::Error` made of it, or [`OtherError::report`], adds the causes (`what: why`).
#[derive(Debug)]
pub struct OtherError(Repr);

#[derive(Debug)]
enum Repr {
    Context {
        message: String,
        source: Option<BoxError>,
    },
    Bare(BoxError),
}

impl OtherError {
    /// A failure said in `message`, with no cause.
    pub fn new(message: impl Into<String>) -> Self {
        Self(Repr::Context {
            message: message.into(),
            source: None,
        })
    }

    /// `message` (what was being done), caused by `source`.
    pub fn context(message: impl Into<String>, source: impl Into<BoxError>) -> Self {
        Self(Repr::Context {
            message: message.into(),
            source: Some(source.into()),
        })
    }

    /// An error as it was raised: its message and causes are its own.
    pub fn wrap(source: impl Into<BoxError>) -> Self {
        Self(Repr::Bare(source.into()))
    }

    /// `e` and its causes, `: `-separated, on one line (as `anyhow` prints `{:#}`).
    pub fn report(e: &(dyn std::error::Error + 'static)) -> String {
        platoon_runtime::Causes(e).to_string()
    }
}

impl Display for OtherError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match &self.0 {
            Repr::Context { message, .. } => f.write_str(message),
            Repr::Bare(e) => e.fmt(f),
        }
    }
}

impl std::error::Error for OtherError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match &self.0 {
            Repr::Context { source, .. } => source.as_deref().map(|e| e as _),
            Repr::Bare(e) => e.source(),
        }
    }
}

impl From<std::io::Error> for OtherError {
    fn from(e: std::io::Error) -> Self {
        Self::wrap(e)
    }
}

impl From<serde_json::Error> for OtherError {
    fn from(e: serde_json::Error) -> Self {
        Self::wrap(e)
    }
}

impl From<csv::Error> for OtherError {
    fn from(e: csv::Error) -> Self {
        Self::wrap(e)
    }
}

/// Words for what failed: an error (or a missing value) as a [`OtherError`] that names what was
/// being done.
pub(crate) trait Context<T> {
    /// `message`, caused by the error.
    fn context(self, message: impl Display) -> Result<T, OtherError>;
    /// The message `message` makes, caused by the error.
    fn with_context<M: Display>(self, message: impl FnOnce() -> M) -> Result<T, OtherError>;
}

impl<T, E: Into<BoxError>> Context<T> for Result<T, E> {
    fn context(self, message: impl Display) -> Result<T, OtherError> {
        self.map_err(|e| OtherError::context(message.to_string(), e))
    }

    fn with_context<M: Display>(self, message: impl FnOnce() -> M) -> Result<T, OtherError> {
        self.map_err(|e| OtherError::context(message().to_string(), e))
    }
}

impl<T> Context<T> for Option<T> {
    fn context(self, message: impl Display) -> Result<T, OtherError> {
        self.ok_or_else(|| OtherError::new(message.to_string()))
    }

    fn with_context<M: Display>(self, message: impl FnOnce() -> M) -> Result<T, OtherError> {
        self.ok_or_else(|| OtherError::new(message().to_string()))
    }
}

/// A [`OtherError`] with the message `format!` makes.
macro_rules! failure {
    ($($message:tt)+) => {
        $crate::error::OtherError::new(format!($($message)+))
    };
}

/// Returns a [`OtherError`] with the message `format!` makes (into the function's error type).
macro_rules! bail {
    ($($message:tt)+) => {
        return Err($crate::error::OtherError::new(format!($($message)+)).into())
    };
}

/// `From` a [`OtherError`] and the errors of JSON, CSV and I/O (all `Other`), for an operation's
/// error enum with an `Other(OtherError)` variant.
macro_rules! operation_error {
    ($error:ident) => {
        impl From<crate::error::OtherError> for $error {
            fn from(e: crate::error::OtherError) -> Self {
                Self::Other(e)
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
