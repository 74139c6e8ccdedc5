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
