//! sqlite3 storage (rosbag2's `.db3`): tables `topics(id, name, type,
//! serialization_format, …)` and `messages(id, topic_id, timestamp, data)`. Each
//! file is opened read-only and immutable (no lock, no journal, nothing written);
//! a topic is read one row at a time by message id (keyset paging), so memory holds
//! one message; the file's pages are read through a memory map.

use rusqlite::{Connection, OpenFlags, OptionalExtension};
use std::path::PathBuf;

/// One topic's messages across the bag's sqlite3 files.
pub(crate) struct Cursor {
    files: Vec<PathBuf>,
    file: usize,
    conn: Option<(Connection, Option<i64>)>,
    last_id: i64,
}

impl Cursor {
    pub(crate) fn new(files: &[PathBuf], _topic: &str) -> Self {
        Cursor { files: files.to_vec(), file: 0, conn: None, last_id: i64::MIN }
    }

    /// The next message of `topic`: (receive time ns, bytes), `None` at the end.
    pub(crate) fn next(&mut self, topic: &str) -> Result<Option<(i64, Vec<u8>)>, String> {
        loop {
            if self.conn.is_none() {
                let Some(path) = self.files.get(self.file) else { return Ok(None) };
                let e = |e: rusqlite::Error| format!("{}: {e}", path.display());
                let uri = format!("file:{}?immutable=1", path.display());
                let flags = OpenFlags::SQLITE_OPEN_READ_ONLY | OpenFlags::SQLITE_OPEN_URI;
                let conn = Connection::open_with_flags(uri, flags).map_err(e)?;
                // Pages read through a memory map (sqlite caps it at 2 GiB of the
                // file): a message's overflow pages are then copied from the map, not
                // read one 4 KiB page per system call. A hint: refused, reads go on.
                let _ = conn.pragma_update(None, "mmap_size", 1i64 << 31);
                let topic_id: Option<i64> = conn
                    .query_row("SELECT id FROM topics WHERE name = ?1", [topic], |r| r.get(0))
                    .optional()
                    .map_err(|x| format!("{} (is it a rosbag2 sqlite3 file?)", e(x)))?;
                self.conn = Some((conn, topic_id));
                self.last_id = i64::MIN;
            }
            let path = &self.files[self.file];
            let (conn, topic_id) = self.conn.as_ref().expect("opened above");
            let row = match topic_id {
                None => None,
                Some(tid) => conn
                    .prepare_cached(
                        "SELECT id, timestamp, data FROM messages WHERE topic_id = ?1 AND id > ?2 ORDER BY id LIMIT 1",
                    )
                    .and_then(|mut s| {
                        s.query_row([*tid, self.last_id], |r| {
                            Ok((r.get::<_, i64>(0)?, r.get::<_, i64>(1)?, r.get::<_, Vec<u8>>(2)?))
                        })
                        .optional()
                    })
                    .map_err(|e| format!("{}: {e}", path.display()))?,
            };
            match row {
                Some((id, t, data)) => {
                    if id <= self.last_id {
                        // Only a damaged file answers `id > last` with a smaller id;
                        // reading on would loop.
                        return Err(format!("{}: message ids out of order (the file is damaged)", path.display()));
                    }
                    self.last_id = id;
                    return Ok(Some((t, data)));
                }
                None => {
                    self.conn = None;
                    self.file += 1;
                }
            }
        }
    }
}
