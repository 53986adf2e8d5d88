//! [`OutputError`], what the fallible functions of this crate return: each variant names the
//! file (or table) and what failed, and keeps the underlying error as its source, so
//! `anyhow`'s `{:#}` prints `what: why` on one line.
use std::path::{Path, PathBuf};

/// The result of this crate's fallible functions.
pub type Result<T, E = OutputError> = std::result::Result<T, E>;

/// Why writing or reading a run's files failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum OutputError {
    /// An I/O operation on `path` failed; `what` says which (`creating <path>`).
    #[error("{what}")]
    Io {
        /// The file or directory.
        path: PathBuf,
        /// What was being done, with the path: the message.
        what: String,
        /// The operating system's error.
        #[source]
        source: std::io::Error,
    },
    /// `path` cannot become a run directory: it exists (without `--force`), is not a
    /// directory, is a mount point, or an earlier replacement left `<path>.old`.
    #[error("{reason}")]
    Refused {
        /// The destination asked for.
        path: PathBuf,
        /// Why, in words, with the path and what to do: the message.
        reason: String,
    },
    /// A table (CSV or Parquet) could not be written, converted or read: a malformed file,
    /// a row that does not fit the schema, or the encoder's error.
    #[error("{what}")]
    Table {
        /// The table's file, or its name for a table kept in memory.
        path: PathBuf,
        /// What was being done, with the file: the message.
        what: String,
        /// The CSV, Parquet or Arrow error.
        #[source]
        source: Box<dyn std::error::Error + Send + Sync>,
    },
    /// The plotting backend failed (the caller's context names the figure's file).
    #[error("{0}")]
    Plot(String),
    /// A SUMO network that is not one, or rows that do not fit it ([`crate::fcd`]).
    #[error("{0}")]
    Fcd(String),
    /// Writing to a stream given by the caller (FCD output) failed.
    #[error(transparent)]
    Stream(#[from] std::io::Error),
}

impl OutputError {
    /// An [`OutputError::Io`] saying `what` of `path`.
    pub(crate) fn io(path: &Path, what: impl Into<String>, source: std::io::Error) -> Self {
        Self::Io {
            path: path.to_path_buf(),
            what: what.into(),
            source,
        }
    }

    /// An [`OutputError::Table`] saying `what` of `path`.
    pub(crate) fn table(
        path: impl Into<PathBuf>,
        what: impl Into<String>,
        source: impl Into<Box<dyn std::error::Error + Send + Sync>>,
    ) -> Self {
        Self::Table {
            path: path.into(),
            what: what.into(),
            source: source.into(),
        }
    }

    /// The file or directory the error is about, when it names one.
    pub fn path(&self) -> Option<&Path> {
        match self {
            Self::Io { path, .. } | Self::Refused { path, .. } | Self::Table { path, .. } => {
                Some(path)
            }
            Self::Plot(_) | Self::Fcd(_) | Self::Stream(_) => None,
        }
    }
}
