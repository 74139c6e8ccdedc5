//! MCAP storage as rosbag2 and `mcap` write it: chunks uncompressed or zstd, small
//! (many messages per chunk, a message larger than a chunk) or large, and a bag split
//! over several files. Every way must read back the messages written, byte for byte,
//! in order, with their log times; messages of uncompressed chunks are borrowed from
//! the memory map (no copy), those of zstd chunks decompressed.

use bpins_ros::metadata::Metadata;
use bpins_ros::msgs::types;
use bpins_ros::writer::{BagWriter, Chunks};
use bpins_ros::Bag;
use std::borrow::Cow;
use std::path::Path;

type Written = Vec<(&'static str, &'static str, i64, Vec<u8>)>;

/// Messages on two topics, in time order: "images" of 1 to 300 KiB (seeded bytes,
/// some compressible, some not) and small "IMU" messages between them.
fn messages() -> Written {
    let mut out = Vec::new();
    let mut x: u64 = 0x9E37_79B9_7F4A_7C15;
    let mut next = || {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        x
    };
    for i in 0..12i64 {
        let t = 1_782_009_000_000_000_000 + i * 100_000_000;
        for dt in [-5_000_000i64, 5_000_000] {
            let imu: Vec<u8> = (0..80).map(|_| next() as u8).collect();
            out.push(("/imu", types::IMU, t + dt, imu));
        }
        let len = [1_000usize, 70_000, 300_000][i as usize % 3] + i as usize;
        let image: Vec<u8> = if i % 2 == 0 {
            (0..len).map(|k| (k / 64) as u8).collect()
        } else {
            (0..len).map(|_| next() as u8).collect()
        };
        out.push(("/cam/image_raw", types::IMAGE, t, image));
    }
    out
}

fn write(dir: &Path, chunks: Chunks, msgs: &[(&str, &str, i64, Vec<u8>)]) {
    let mut w = BagWriter::create_with(dir, chunks).unwrap();
    for (topic, ty, t, data) in msgs {
        w.write(topic, ty, *t, data).unwrap();
    }
    w.finish().unwrap();
}

/// Every topic's messages read back: (index, log time, bytes, borrowed from the map).
fn read(dir: &Path, topic: &str) -> Vec<(u64, i64, Vec<u8>, bool)> {
    let bag = Bag::open(dir).unwrap();
    bag.cursor(topic)
        .unwrap()
        .map(|m| {
            let m = m.unwrap();
            let borrowed = matches!(m.data, Cow::Borrowed(_));
            (m.index, m.log_time_ns, m.data.into_owned(), borrowed)
        })
        .collect()
}

fn want(msgs: &[(&str, &str, i64, Vec<u8>)], topic: &str) -> Vec<(u64, i64, Vec<u8>)> {
    msgs.iter().filter(|m| m.0 == topic).enumerate().map(|(k, m)| (k as u64, m.2, m.3.clone())).collect()
}

#[test]
fn uncompressed_and_zstd_chunks_of_any_size_read_back_the_messages_written() {
    let tmp = tempfile::tempdir().unwrap();
    let msgs = messages();
    for (name, chunks) in [
        ("plain_small", Chunks { zstd: false, size_bytes: 4096 }),
        ("plain_default", Chunks::default()),
        ("zstd_small", Chunks { zstd: true, size_bytes: 4096 }),
        ("zstd_large", Chunks { zstd: true, size_bytes: 64 << 20 }),
    ] {
        let dir = tmp.path().join(name);
        write(&dir, chunks, &msgs);
        let bytes = std::fs::read(dir.join(format!("{name}_0.mcap"))).unwrap();
        // The chunks are what they say: zstd's frame magic (28 b5 2f fd) in the file
        // or not (the images' random bytes cannot hold it by chance: checked here).
        let zstd_magic = bytes.windows(4).any(|w| w == [0x28, 0xb5, 0x2f, 0xfd]);
        assert_eq!(zstd_magic, chunks.zstd, "{name}");
        for topic in ["/imu", "/cam/image_raw"] {
            let got = read(&dir, topic);
            let plain: Vec<(u64, i64, Vec<u8>)> = got.iter().map(|g| (g.0, g.1, g.2.clone())).collect();
            assert!(plain == want(&msgs, topic), "{name} {topic}: the messages read differ from those written");
            // Zero copy from the map for uncompressed chunks; decompressed otherwise.
            assert!(
                got.iter().all(|g| g.3 != chunks.zstd),
                "{name} {topic}: borrowed {:?}",
                got.iter().map(|g| g.3).collect::<Vec<_>>()
            );
        }
        if chunks.zstd {
            // A zstd chunk's frame damaged (its magic flipped): an error naming the
            // file, never a panic.
            let damaged = tmp.path().join(format!("{name}_damaged"));
            std::fs::create_dir(&damaged).unwrap();
            let mut b = bytes.clone();
            let at = b.windows(4).position(|w| w == [0x28, 0xb5, 0x2f, 0xfd]).unwrap();
            b[at] ^= 0x5a;
            std::fs::write(damaged.join(format!("{name}_0.mcap")), &b).unwrap();
            std::fs::copy(dir.join("metadata.yaml"), damaged.join("metadata.yaml")).unwrap();
            let bag = Bag::open(&damaged).unwrap();
            let all: Vec<_> =
                ["/imu", "/cam/image_raw"].iter().flat_map(|t| bag.cursor(t).unwrap().collect::<Vec<_>>()).collect();
            let e = all.iter().find_map(|r| r.as_ref().err()).expect("the damage is found");
            assert!(e.to_string().contains(&format!("{name}_0.mcap")), "{e}");
        }
    }
}

#[test]
fn a_bag_split_over_files_reads_as_one() {
    // rosbag2 `--max-bag-size`: NAME_0.mcap, NAME_1.mcap, … listed in metadata.yaml,
    // each file with channels of its own (here: numbered in another order).
    let tmp = tempfile::tempdir().unwrap();
    let msgs = messages();
    let (a, b) = msgs.split_at(msgs.len() / 2 + 1);
    let mut b = b.to_vec();
    // The second file's first message on the image topic, so its channel ids differ.
    let first_image = b.iter().position(|m| m.0 == "/cam/image_raw").unwrap();
    let im = b.remove(first_image);
    b.insert(0, im);
    let parts = [
        (tmp.path().join("p0"), a.to_vec(), Chunks::default()),
        (tmp.path().join("p1"), b.clone(), Chunks { zstd: true, size_bytes: 8192 }),
    ];
    for (dir, m, c) in &parts {
        write(dir, *c, m);
    }
    let split = tmp.path().join("split");
    std::fs::create_dir(&split).unwrap();
    let mut meta = Metadata::parse(&std::fs::read_to_string(parts[0].0.join("metadata.yaml")).unwrap()).unwrap();
    meta.relative_file_paths = vec!["split_0.mcap".into(), "split_1.mcap".into()];
    meta.files.clear();
    std::fs::rename(parts[0].0.join("p0_0.mcap"), split.join("split_0.mcap")).unwrap();
    std::fs::rename(parts[1].0.join("p1_0.mcap"), split.join("split_1.mcap")).unwrap();
    std::fs::write(split.join("metadata.yaml"), meta.to_yaml()).unwrap();
    let all: Written = [a.to_vec(), b].concat();
    for topic in ["/imu", "/cam/image_raw"] {
        let got: Vec<(u64, i64, Vec<u8>)> = read(&split, topic).into_iter().map(|g| (g.0, g.1, g.2)).collect();
        assert!(got == want(&all, topic), "{topic}: {} messages read, {} written", got.len(), want(&all, topic).len());
    }
    // A file listed but absent: refused when the bag is opened, naming it.
    std::fs::remove_file(split.join("split_1.mcap")).unwrap();
    let e = Bag::open(&split).err().expect("refused").to_string();
    assert!(e.contains("split_1.mcap"), "{e}");
}

#[test]
fn lz4_chunks_are_refused_by_name() {
    // rosbag2 can be told to write lz4 chunks; bpins builds `mcap` without lz4. A zstd
    // bag's first chunk relabelled `lz4` (its compression string and record length
    // rewritten; the file's later offsets are not read by the linear walk).
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("z");
    write(&dir, Chunks { zstd: true, size_bytes: 4096 }, &messages());
    let b = std::fs::read(dir.join("z_0.mcap")).unwrap();
    let i = b.windows(8).position(|w| w == b"\x04\x00\x00\x00zstd").unwrap();
    let chunk = i - (1 + 8 + 8 + 8 + 8 + 4);
    assert_eq!(b[chunk], 0x06, "not a chunk record");
    let len = u64::from_le_bytes(b[chunk + 1..chunk + 9].try_into().unwrap()) - 1;
    let mut out = b[..i].to_vec();
    out[chunk + 1..chunk + 9].copy_from_slice(&len.to_le_bytes());
    out.extend_from_slice(b"\x03\x00\x00\x00lz4");
    out.extend_from_slice(&b[i + 8..]);
    let lz4 = tmp.path().join("lz4");
    std::fs::create_dir(&lz4).unwrap();
    std::fs::write(lz4.join("z_0.mcap"), &out).unwrap();
    std::fs::copy(dir.join("metadata.yaml"), lz4.join("metadata.yaml")).unwrap();
    let bag = Bag::open(&lz4).unwrap();
    let e = bag.cursor("/imu").unwrap().find_map(|r| r.err()).expect("refused").to_string();
    assert!(e.contains("lz4") && e.contains("bpins reads uncompressed and zstd MCAP chunks"), "{e}");
    assert!(e.contains("topic /imu, message 0"), "{e}");
}

/// Every message of `topic` through a cursor of its own: (index, log time, bytes).
fn alone(bag: &Bag, topic: &str) -> Vec<(u64, i64, Vec<u8>)> {
    bag.cursor(topic).unwrap().map(|m| m.unwrap()).map(|m| (m.index, m.log_time_ns, m.data.into_owned())).collect()
}

/// The same bag in sqlite3 storage: the MCAP bag's messages copied into rosbag2's
/// tables, in the MCAP file's order.
fn as_sqlite(mcap_dir: &Path, dir: &Path) {
    let bag = Bag::open(mcap_dir).unwrap();
    std::fs::create_dir_all(dir).unwrap();
    let name = dir.file_name().unwrap().to_str().unwrap();
    let db = rusqlite::Connection::open(dir.join(format!("{name}_0.db3"))).unwrap();
    db.execute_batch(
        "CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT NOT NULL, type TEXT NOT NULL, \
         serialization_format TEXT NOT NULL, offered_qos_profiles TEXT NOT NULL); \
         CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER NOT NULL, timestamp INTEGER NOT NULL, \
         data BLOB NOT NULL);",
    )
    .unwrap();
    let names: Vec<&str> = bag.topics.iter().map(|t| t.name.as_str()).collect();
    for (k, t) in bag.topics.iter().enumerate() {
        db.execute(
            "INSERT INTO topics VALUES (?1, ?2, ?3, 'cdr', '')",
            rusqlite::params![k as i64 + 1, t.name, t.type_name],
        )
        .unwrap();
    }
    for m in bag.messages(&names) {
        let (k, m) = m.unwrap();
        db.execute(
            "INSERT INTO messages (topic_id, timestamp, data) VALUES (?1, ?2, ?3)",
            rusqlite::params![k as i64 + 1, m.log_time_ns, &m.data[..]],
        )
        .unwrap();
    }
    let mut meta = bag.metadata.clone();
    meta.storage_identifier = "sqlite3".into();
    meta.relative_file_paths = vec![format!("{name}_0.db3")];
    meta.files.clear();
    std::fs::write(dir.join("metadata.yaml"), meta.to_yaml()).unwrap();
}

/// Issue 50 item 3: the topics a run reads come from one walk of the storage. The
/// cursors of [`Bag::cursors`], read in step as the image route reads them (each
/// image, then the IMU samples up to its time), or one drained before the other,
/// give each topic's messages exactly as a cursor of its own does, and a zstd bag's
/// chunks are each decompressed once, where cursors of their own decompress each
/// chunk once per topic.
#[test]
fn cursors_of_several_topics_share_one_walk_and_read_what_cursors_of_their_own_read() {
    let tmp = tempfile::tempdir().unwrap();
    let msgs = messages();
    let zstd = tmp.path().join("zstd");
    write(&zstd, Chunks { zstd: true, size_bytes: 16 << 10 }, &msgs);
    let sqlite = tmp.path().join("sqlite");
    as_sqlite(&zstd, &sqlite);
    let plain = tmp.path().join("plain");
    write(&plain, Chunks { zstd: false, size_bytes: 16 << 10 }, &msgs);
    let topics = ["/cam/image_raw", "/imu"];
    for dir in [&zstd, &sqlite, &plain] {
        let bag = Bag::open(dir).unwrap();
        let want: Vec<_> = topics.iter().map(|t| alone(&bag, t)).collect();
        assert_eq!(want[0], self::want(&msgs, topics[0]));
        let own_walks = bag.chunks_decompressed();
        // In step: an image, then the IMU up to and including the first sample after it.
        let before = bag.chunks_decompressed();
        let mut c = bag.cursors(&topics).unwrap().into_iter();
        let (mut images, mut imu) = (c.next().unwrap(), c.next().unwrap());
        let mut got = [Vec::new(), Vec::new()];
        for m in images.by_ref() {
            let m = m.unwrap();
            let t = m.log_time_ns;
            got[0].push((m.index, m.log_time_ns, m.data.into_owned()));
            while got[1].last().is_none_or(|s: &(u64, i64, Vec<u8>)| s.1 <= t) {
                match imu.next() {
                    Some(s) => {
                        let s = s.unwrap();
                        got[1].push((s.index, s.log_time_ns, s.data.into_owned()));
                    }
                    None => break,
                }
            }
        }
        got[1].extend(imu.map(|s| s.unwrap()).map(|s| (s.index, s.log_time_ns, s.data.into_owned())));
        assert!(got[0] == want[0] && got[1] == want[1], "{}: in step", dir.display());
        let shared_walk = bag.chunks_decompressed() - before;
        // One cursor drained first: the other's messages wait for it.
        let mut c = bag.cursors(&topics).unwrap();
        let imu: Vec<_> =
            c.pop().unwrap().map(|m| m.unwrap()).map(|m| (m.index, m.log_time_ns, m.data.into_owned())).collect();
        let images: Vec<_> =
            c.pop().unwrap().map(|m| m.unwrap()).map(|m| (m.index, m.log_time_ns, m.data.into_owned())).collect();
        assert!(images == want[0] && imu == want[1], "{}: one after the other", dir.display());
        // The one walk over both topics, message by message, in storage order.
        let mut by_walk = [Vec::new(), Vec::new()];
        for m in bag.messages(&topics) {
            let (k, m) = m.unwrap();
            by_walk[k].push((m.index, m.log_time_ns, m.data.into_owned()));
        }
        assert!(by_walk[0] == want[0] && by_walk[1] == want[1], "{}: messages()", dir.display());
        if dir == &zstd {
            assert!(shared_walk >= 4, "{shared_walk} chunks");
            assert_eq!(own_walks, 2 * shared_walk, "cursors of their own decompress each chunk once per topic");
        } else {
            assert_eq!(bag.chunks_decompressed(), 0);
        }
    }
}

/// Issue 50 item 3: storage errors keep the error they come from as their source,
/// typed, and name the file.
#[test]
fn storage_errors_keep_their_source() {
    use std::error::Error;
    let tmp = tempfile::tempdir().unwrap();
    // No bag at all: metadata.yaml missing, the OS's NotFound the source.
    let e = Bag::open(&tmp.path().join("nowhere")).err().expect("refused");
    let io = e.source().and_then(|s| s.downcast_ref::<std::io::Error>()).expect("an io::Error source");
    assert_eq!(io.kind(), std::io::ErrorKind::NotFound);
    assert!(matches!(e, bpins_ros::BagError::Io { .. }) && e.to_string().contains("metadata.yaml"), "{e}");
    // A storage file listed but missing, MCAP and sqlite3.
    let mcap = tmp.path().join("m");
    write(&mcap, Chunks::default(), &messages());
    let sqlite = tmp.path().join("s");
    as_sqlite(&mcap, &sqlite);
    for (dir, file) in [(&mcap, "m_0.mcap"), (&sqlite, "s_0.db3")] {
        let gone = tmp.path().join(format!("{file}_gone"));
        std::fs::create_dir(&gone).unwrap();
        std::fs::copy(dir.join("metadata.yaml"), gone.join("metadata.yaml")).unwrap();
        let e = Bag::open(&gone).err().expect("refused");
        let io = e.source().and_then(|s| s.downcast_ref::<std::io::Error>()).expect("an io::Error source");
        assert_eq!(io.kind(), std::io::ErrorKind::NotFound, "{file}");
        assert!(e.to_string().contains(file), "{e}");
    }
    // A sqlite3 file that is not a database: SQLite's error the source.
    let bad = tmp.path().join("bad");
    std::fs::create_dir(&bad).unwrap();
    std::fs::copy(sqlite.join("metadata.yaml"), bad.join("metadata.yaml")).unwrap();
    std::fs::write(bad.join("s_0.db3"), vec![0x5a; 8192]).unwrap();
    let bag = Bag::open(&bad).unwrap();
    let e = bag.cursor("/imu").unwrap().find_map(|r| r.err()).expect("refused");
    let sq = e.source().and_then(|s| s.downcast_ref::<rusqlite::Error>()).expect("a rusqlite::Error source");
    assert_eq!(sq.sqlite_error_code(), Some(rusqlite::ErrorCode::NotADatabase), "{sq}");
    assert!(matches!(e, bpins_ros::BagError::Sqlite(_)), "{e:?}");
    assert!(e.to_string().contains("s_0.db3") && e.to_string().contains("topic /imu, message 0"), "{e}");
    // An MCAP chunk of a compression bpins does not read (a zstd chunk relabelled
    // `lz4`, as in lz4_chunks_are_refused_by_name): told by the type of mcap's error.
    let z = tmp.path().join("z");
    write(&z, Chunks { zstd: true, size_bytes: 4096 }, &messages());
    let b = std::fs::read(z.join("z_0.mcap")).unwrap();
    let i = b.windows(8).position(|w| w == b"\x04\x00\x00\x00zstd").unwrap();
    let chunk = i - (1 + 8 + 8 + 8 + 8 + 4);
    let len = u64::from_le_bytes(b[chunk + 1..chunk + 9].try_into().unwrap()) - 1;
    let mut out = b[..i].to_vec();
    out[chunk + 1..chunk + 9].copy_from_slice(&len.to_le_bytes());
    out.extend_from_slice(b"\x03\x00\x00\x00lz4");
    out.extend_from_slice(&b[i + 8..]);
    std::fs::write(z.join("z_0.mcap"), &out).unwrap();
    let bag = Bag::open(&z).unwrap();
    let e = bag.cursor("/imu").unwrap().find_map(|r| r.err()).expect("refused");
    let source = e.source().and_then(|s| s.downcast_ref::<mcap::McapError>());
    assert!(matches!(source, Some(mcap::McapError::UnsupportedCompression(c)) if c == "lz4"), "{e:?}");
    assert!(matches!(e, bpins_ros::BagError::Mcap(_)) && e.to_string().contains("z_0.mcap"), "{e}");
}
