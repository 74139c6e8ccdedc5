//! Typed errors of the bag reader and writer: each names the bag and, where there is
//! one, the topic and the message's index on that topic (0-based, in storage order).

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
    /// The folder, its metadata.yaml or a storage file is missing or unreadable.
    #[error("{at}: {message}")]
    Io { at: Where, message: String },
    /// metadata.yaml is not a rosbag2 description this reader understands.
    #[error("{at}: metadata.yaml: {message}")]
    Metadata { at: Where, message: String },
    /// The storage file (MCAP or sqlite3) is damaged or truncated.
    #[error("{at}: {message}")]
    Storage { at: Where, message: String },
    /// A message that does not decode as its type, or whose content is refused
    /// (an unknown encoding, a size that does not match the camera, NaN).
    #[error("{at}: {message}")]
    Message { at: Where, message: String },
    /// A topic asked for is not in the bag, or is of another type.
    #[error("{at}: {message}")]
    Topic { at: Where, message: String },
    /// Writing the output bag failed.
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
        }
    }
}
