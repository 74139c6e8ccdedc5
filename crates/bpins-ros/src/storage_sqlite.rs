//! sqlite3 storage (rosbag2's `.db3`): tables `topics(id, name, type,
//! serialization_format, …)` and `messages(id, topic_id, timestamp, data)`. Each
//! file is opened read-only and immutable (no lock, no journal, nothing written);
//! a topic is read one row at a time by message id (keyset paging), so memory holds
//! one message; the file's pages are read through a memory map, and a message's
//! bytes by SQLite's incremental blob API straight into its buffer.

use rusqlite::{ffi, Connection, OpenFlags, OptionalExtension};
use std::ffi::{c_int, c_void, CStr};
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
                        "SELECT id, timestamp FROM messages WHERE topic_id = ?1 AND id > ?2 ORDER BY id LIMIT 1",
                    )
                    .and_then(|mut s| {
                        s.query_row([*tid, self.last_id], |r| Ok((r.get::<_, i64>(0)?, r.get::<_, i64>(1)?))).optional()
                    })
                    .map_err(|e| format!("{}: {e}", path.display()))?,
            };
            match row {
                Some((id, t)) => {
                    let data = read_data(conn, id).map_err(|e| format!("{}: message row {id}: {e}", path.display()))?;
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

/// `messages.data` of the row `id` (rosbag2's `id INTEGER PRIMARY KEY` is the rowid),
/// read by SQLite's incremental blob API straight into one buffer: a `SELECT` of the
/// column would first assemble the value in a buffer of SQLite's and then copy it
/// into ours (two passes over a 10 MB frame instead of one). A value that is not a
/// blob (a damaged file) is read through a `SELECT`.
fn read_data(conn: &Connection, id: i64) -> Result<Vec<u8>, String> {
    // SAFETY: `conn` is open for the whole call and used by this thread only; the
    // blob handle is closed on every path (closing a null handle, left by a failed
    // open, is a no-op); `sqlite3_blob_read` writes exactly `n` bytes into the
    // vector's allocated capacity of `n` or fails, and the length is set only when
    // it succeeded; the error text is copied before the next SQLite call.
    unsafe {
        let db = conn.handle();
        let msg = |what: &str| format!("{what}: {}", CStr::from_ptr(ffi::sqlite3_errmsg(db)).to_string_lossy());
        let mut blob: *mut ffi::sqlite3_blob = std::ptr::null_mut();
        let rc = ffi::sqlite3_blob_open(db, c"main".as_ptr(), c"messages".as_ptr(), c"data".as_ptr(), id, 0, &mut blob);
        if rc != ffi::SQLITE_OK {
            ffi::sqlite3_blob_close(blob);
            return conn
                .query_row("SELECT data FROM messages WHERE id = ?1", [id], |r| r.get::<_, Vec<u8>>(0))
                .map_err(|e| e.to_string());
        }
        let n = ffi::sqlite3_blob_bytes(blob).max(0);
        let mut v: Vec<u8> = Vec::with_capacity(n as usize);
        let rc = ffi::sqlite3_blob_read(blob, v.as_mut_ptr().cast::<c_void>(), n as c_int, 0);
        let err = (rc != ffi::SQLITE_OK).then(|| msg("reading its data"));
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
