//! Typed errors of the bag reader and writer: each names the bag and, where there is
//! one, the topic and the message's index on that topic (0-based, in storage order).
//! A failure of the file system, of SQLite or of the `mcap` crate is kept whole as the
//! error's [`std::error::Error::source`] (its own message is not repeated in the
//! error's: `{:#}` or a source chain prints both), so a caller can tell a missing
//! file from a damaged one by its type, never by its text.

use std::fmt;
use std::path::PathBuf;

/// Where in a bag an error was found.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Where {
    pub bag: PathBuf,
    pub topic: Option<String>,
    /// 0-based index of the message on its topic, in storage order.
    pub index: Option<u64>,
}

impl fmt::Display for Where {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "bag {}", self.bag.display())?;
        if let Some(t) = &self.topic {
            write!(f, ", topic {t}")?;
        }
        if let Some(i) = self.index {
            write!(f, ", message {i}")?;
        }
        Ok(())
    }
}

#[derive(Debug, thiserror::Error)]
pub enum BagError {
    /// A file of the bag (its metadata.yaml, a storage file), or of a bag being
    /// written, that cannot be opened, mapped, read or written: `path` names it,
    /// `message` says what was done; the OS error is the source.
    #[error("{at}: {}: {message}", path.display())]
    Io {
        at: Where,
        path: PathBuf,
        message: String,
        #[source]
        source: std::io::Error,
    },
    /// metadata.yaml is not a rosbag2 description this reader understands.
    #[error("{at}: metadata.yaml: {message}")]
    Metadata { at: Where, message: String },
    /// A sqlite3 storage file that SQLite refuses or fails to read (not a database,
    /// damaged pages, no rosbag2 tables): the file and what was read; SQLite's error
    /// is the source.
    #[error(transparent)]
    Sqlite(Box<Failure<rusqlite::Error>>),
    /// An MCAP storage file whose records the `mcap` crate refuses (a damaged record
    /// or chunk, a chunk compression bpins does not read), or an MCAP file being
    /// written that it fails to write: the file and what was done; `mcap`'s error is
    /// the source.
    #[error(transparent)]
    Mcap(Box<Failure<mcap::McapError>>),
    /// The storage file (MCAP or sqlite3) is damaged or truncated, as bpins' own
    /// checks of its framing find (the message names the file).
    #[error("{at}: {message}")]
    Storage { at: Where, message: String },
    /// A message that does not decode as its type, or whose content is refused
    /// (an unknown encoding, a size that does not match the camera, NaN).
    #[error("{at}: {message}")]
    Message { at: Where, message: String },
    /// A topic asked for is not in the bag, or is of another type.
    #[error("{at}: {message}")]
    Topic { at: Where, message: String },
    /// Writing the output bag was refused (bpins never writes into an existing
    /// folder, a topic keeps its type); failures of the file system or of `mcap`
    /// while writing are [`BagError::Io`] and [`BagError::Mcap`].
    #[error("{at}: {message}")]
    Write { at: Where, message: String },
}

impl BagError {
    /// Where the error was found.
    pub fn at(&self) -> &Where {
        match self {
            BagError::Io { at, .. }
            | BagError::Metadata { at, .. }
            | BagError::Storage { at, .. }
            | BagError::Message { at, .. }
            | BagError::Topic { at, .. }
            | BagError::Write { at, .. } => at,
            BagError::Sqlite(f) => &f.at,
            BagError::Mcap(f) => &f.at,
        }
    }
}

/// A file of a bag that a library (SQLite, `mcap`) failed on: where, the file, what
/// was done, and the library's error whole as the source. Boxed in [`BagError`], so
/// that a `Result` of a message stays small.
#[derive(Debug, thiserror::Error)]
#[error("{at}: {}: {message}", path.display())]
pub struct Failure<E: std::error::Error + 'static> {
    pub at: Where,
    pub path: PathBuf,
    pub message: String,
    #[source]
    pub source: E,
}

/// A storage file's failure before the reader knows where in the bag it lies (which
/// topic and message): [`Fault::at`] makes it a [`BagError`].
#[derive(Debug)]
pub(crate) enum Fault {
    Sqlite {
        path: PathBuf,
        message: String,
        source: rusqlite::Error,
    },
    Mcap {
        path: PathBuf,
        message: String,
        source: mcap::McapError,
    },
    /// Found by bpins' own checks; the message names the file.
    Damaged(String),
}

impl Fault {
    pub(crate) fn at(self, at: Where) -> BagError {
        match self {
            Fault::Sqlite { path, message, source } => {
                BagError::Sqlite(Box::new(Failure { at, path, message, source }))
            }
            Fault::Mcap { path, message, source } => BagError::Mcap(Box::new(Failure { at, path, message, source })),
            Fault::Damaged(message) => BagError::Storage { at, message },
        }
    }
}
