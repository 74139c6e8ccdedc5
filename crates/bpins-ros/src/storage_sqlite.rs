//! sqlite3 storage (rosbag2's `.db3`): tables `topics(id, name, type,
//! serialization_format, …)` and `messages(id, topic_id, timestamp, data)`. Each
//! file is opened read-only and immutable (no lock, no journal, nothing written);
//! the topics a run reads are walked together, one row at a time by message id
//! (keyset paging), so memory holds one message and each row is visited once; the
//! file's pages are read through a memory map, and a message's bytes by SQLite's
//! incremental blob API straight into its buffer.

use crate::error::Fault;
use rusqlite::{ffi, Connection, OpenFlags, OptionalExtension};
use std::collections::HashMap;
use std::ffi::{c_int, c_void, CStr};
use std::path::{Path, PathBuf};

/// An open storage file: its connection, the slot of each of its topic ids that is
/// read, and the query of the next message of those topics.
struct Open {
    conn: Connection,
    slots: HashMap<i64, usize>,
    next_sql: String,
}

/// The messages of a set of topics across the bag's sqlite3 files, in storage order
/// (message id), in one walk.
pub(crate) struct Stream {
    files: Vec<PathBuf>,
    topics: Vec<String>,
    file: usize,
    open: Option<Open>,
    last_id: i64,
}

fn fault(path: &Path, message: &str) -> impl FnOnce(rusqlite::Error) -> Fault {
    let (path, message) = (path.to_path_buf(), message.to_string());
    move |source| Fault::Sqlite { path, message, source }
}

impl Stream {
    pub(crate) fn new(files: &[PathBuf], topics: &[&str]) -> Self {
        Stream {
            files: files.to_vec(),
            topics: topics.iter().map(|t| t.to_string()).collect(),
            file: 0,
            open: None,
            last_id: i64::MIN,
        }
    }

    /// Opens `path` read-only and immutable, and finds the ids of the topics read.
    fn open(&self, path: &Path) -> Result<Open, Fault> {
        let uri = format!("file:{}?immutable=1", path.display());
        let flags = OpenFlags::SQLITE_OPEN_READ_ONLY | OpenFlags::SQLITE_OPEN_URI;
        let conn = Connection::open_with_flags(uri, flags).map_err(fault(path, "cannot be opened by SQLite"))?;
        // Pages read through a memory map (sqlite caps it at 2 GiB of the file): a
        // message's overflow pages are then copied from the map, not read one 4 KiB
        // page per system call. A hint: refused, reads go on.
        let _ = conn.pragma_update(None, "mmap_size", 1i64 << 31);
        let mut slots = HashMap::new();
        {
            let not_rosbag2 = "its topics table cannot be read (is it a rosbag2 sqlite3 file?)";
            let mut q = conn.prepare("SELECT id, name FROM topics").map_err(fault(path, not_rosbag2))?;
            let rows = q.query_map([], |r| Ok((r.get::<_, i64>(0)?, r.get::<_, String>(1)?)));
            for row in rows.map_err(fault(path, not_rosbag2))? {
                let (id, name) = row.map_err(fault(path, not_rosbag2))?;
                if let Some(slot) = self.topics.iter().position(|t| *t == name) {
                    slots.insert(id, slot);
                }
            }
        }
        // The topic ids are the file's own integers, written into the query as such.
        let mut ids: Vec<i64> = slots.keys().copied().collect();
        ids.sort_unstable();
        let list = ids.iter().map(i64::to_string).collect::<Vec<_>>().join(", ");
        let next_sql = format!(
            "SELECT id, topic_id, timestamp FROM messages WHERE id > ?1 AND topic_id IN ({list}) ORDER BY id LIMIT 1"
        );
        Ok(Open { conn, slots, next_sql })
    }

    /// The next message of the topics: (slot, receive time ns, bytes), `None` at the
    /// end. After an error the stream is not used again.
    pub(crate) fn next(&mut self) -> Result<Option<(usize, i64, Vec<u8>)>, Fault> {
        loop {
            let Some(path) = self.files.get(self.file) else { return Ok(None) };
            if self.open.is_none() {
                self.open = Some(self.open(path)?);
                self.last_id = i64::MIN;
            }
            let open = self.open.as_ref().expect("opened above");
            // Keyset paging: the first row of the topics after the last one read (an
            // index seek on the rowid, then a walk to the next row of the topics).
            let row = if open.slots.is_empty() {
                None
            } else {
                open.conn
                    .prepare_cached(&open.next_sql)
                    .and_then(|mut s| {
                        s.query_row([self.last_id], |r| {
                            Ok((r.get::<_, i64>(0)?, r.get::<_, i64>(1)?, r.get::<_, i64>(2)?))
                        })
                        .optional()
                    })
                    .map_err(fault(path, "its messages table cannot be read"))?
            };
            match row {
                Some((id, topic_id, t)) => {
                    let data = read_data(&open.conn, id).map_err(fault(path, &format!("message row {id}")))?;
                    if id <= self.last_id {
                        // Only a damaged file answers `id > last` with a smaller id;
                        // reading on would loop.
                        return Err(Fault::Damaged(format!(
                            "{}: message ids out of order (the file is damaged)",
                            path.display()
                        )));
                    }
                    let Some(&slot) = open.slots.get(&topic_id) else {
                        return Err(Fault::Damaged(format!(
                            "{}: message row {id} of topic id {topic_id}, which was not asked for (the file is damaged)",
                            path.display()
                        )));
                    };
                    self.last_id = id;
                    return Ok(Some((slot, t, data)));
                }
                None => {
                    self.open = None;
                    self.file += 1;
                }
            }
        }
    }
}

/// `messages.data` of the row `id` (rosbag2's `id INTEGER PRIMARY KEY` is the rowid),
/// read by SQLite's incremental blob API straight into one buffer: a `SELECT` of the
/// column would first assemble the value in a buffer of SQLite's and then copy it
/// into ours (two passes over a 10 MB frame instead of one). A value that is not a
/// blob (a damaged file) is read through a `SELECT`.
fn read_data(conn: &Connection, id: i64) -> Result<Vec<u8>, rusqlite::Error> {
    // SAFETY: `conn` is open for the whole call and used by this thread only; the
    // blob handle is closed on every path (closing a null handle, left by a failed
    // open, is a no-op); `sqlite3_blob_read` writes exactly `n` bytes into the
    // vector's allocated capacity of `n` or fails, and the length is set only when
    // it succeeded; the error text is copied before the next SQLite call.
    unsafe {
        let db = conn.handle();
        let mut blob: *mut ffi::sqlite3_blob = std::ptr::null_mut();
        let rc = ffi::sqlite3_blob_open(db, c"main".as_ptr(), c"messages".as_ptr(), c"data".as_ptr(), id, 0, &mut blob);
        if rc != ffi::SQLITE_OK {
            ffi::sqlite3_blob_close(blob);
            return conn.query_row("SELECT data FROM messages WHERE id = ?1", [id], |r| r.get::<_, Vec<u8>>(0));
        }
        let n = ffi::sqlite3_blob_bytes(blob).max(0);
        let mut v: Vec<u8> = Vec::with_capacity(n as usize);
        let rc = ffi::sqlite3_blob_read(blob, v.as_mut_ptr().cast::<c_void>(), n as c_int, 0);
        // SQLite's error, as rusqlite gives it for its own calls: the code and the
        // connection's message.
        let err = (rc != ffi::SQLITE_OK).then(|| {
            let text = CStr::from_ptr(ffi::sqlite3_errmsg(db)).to_string_lossy().into_owned();
            rusqlite::Error::SqliteFailure(ffi::Error::new(rc), Some(format!("reading its data: {text}")))
        });
        ffi::sqlite3_blob_close(blob);
        match err {
            Some(e) => Err(e),
            None => {
                v.set_len(n as usize);
                Ok(v)
            }
        }
    }
}
