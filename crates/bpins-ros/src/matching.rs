//! Samples of a slow topic (IMU, GNSS) matched to each image's stamp, by header
//! stamps: a [`Track`] walks its topic forward and keeps the last sample at or
//! before the image and the first after it, so a bag of any length costs two
//! samples. Images must come in nondecreasing stamp order for the match to be the
//! nearest (a camera driver's order); a sample that cannot be used (NaN, no fix)
//! is kept with its reason, and a frame that needs it is skipped with that reason.

use crate::cdr::decode;
use crate::convert::{imu_orientation, tilt_of, Tilt};
use crate::error::BagError;
use crate::msgs::{Imu, NavSatFix};
use crate::reader::TopicCursor;
use glam::DQuat;

/// One sample of a track: its header stamp, its index on the topic, its value or
/// why it cannot be used.
#[derive(Clone, Debug)]
pub struct Stamped<T> {
    pub stamp_ns: i64,
    pub index: u64,
    pub value: Result<T, String>,
}

/// One message decoded: its stamp and value (or why the value is unusable); an
/// `Err` is a message that does not decode at all (a damaged bag).
pub type Decoded<T> = Result<(i64, Result<T, String>), String>;

/// Decodes one message for a [`Track`].
pub type Decoder<T> = fn(&[u8]) -> Decoded<T>;

/// The samples around a stamp: the last at or before it, the first after it.
pub type Around<'t, T> = (Option<&'t Stamped<T>>, Option<&'t Stamped<T>>);

/// A topic walked forward in step with the images.
pub struct Track<'a, T> {
    cursor: TopicCursor<'a>,
    decode: Decoder<T>,
    prev: Option<Stamped<T>>,
    next: Option<Stamped<T>>,
    started: bool,
}

impl<'a, T> Track<'a, T> {
    pub fn new(cursor: TopicCursor<'a>, decode: Decoder<T>) -> Self {
        Track { cursor, decode, prev: None, next: None, started: false }
    }

    /// The topic's name.
    pub fn topic(&self) -> &str {
        self.cursor.topic()
    }

    fn read(&mut self) -> Result<Option<Stamped<T>>, BagError> {
        match self.cursor.next() {
            None => Ok(None),
            Some(Err(e)) => Err(e),
            Some(Ok(m)) => {
                let (stamp_ns, value) = (self.decode)(&m.data)
                    .map_err(|message| BagError::Message { at: self.cursor.at(m.index), message })?;
                Ok(Some(Stamped { stamp_ns, index: m.index, value }))
            }
        }
    }

    /// The last sample stamped at or before `t_ns` and the first after it.
    pub fn around(&mut self, t_ns: i64) -> Result<Around<'_, T>, BagError> {
        if !self.started {
            self.started = true;
            self.next = self.read()?;
        }
        while self.next.as_ref().is_some_and(|n| n.stamp_ns <= t_ns) {
            self.prev = self.next.take();
            self.next = self.read()?;
        }
        Ok((self.prev.as_ref(), self.next.as_ref()))
    }

    /// Why a sample cannot be used, naming the topic and message index.
    pub fn why(&self, s: &Stamped<T>) -> Option<String> {
        s.value.as_ref().err().map(|e| format!("{}: {e}", self.cursor.at(s.index)))
    }
}

/// How an IMU sample is matched to an image's stamp.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImuMatch {
    /// The sample nearest in time.
    Nearest,
    /// The two samples around the stamp, orientation slerped, variances linear
    /// (the nearest alone at either end of the topic).
    Interpolate,
}

/// An IMU sample: `world_from_body` (x, y, z, w) and the roll and pitch variances.
pub type ImuSample = ([f64; 4], f64, f64);

/// Decodes a `sensor_msgs/Imu` for a [`Track`].
pub fn decode_imu(bytes: &[u8]) -> Decoded<ImuSample> {
    let m: Imu = decode(bytes)?;
    Ok((m.header.stamp.ns(), imu_orientation(&m)))
}

/// Decodes a `sensor_msgs/NavSatFix` for a [`Track`]: (latitude, longitude), degrees.
pub fn decode_fix(bytes: &[u8]) -> Decoded<(f64, f64)> {
    let m: NavSatFix = decode(bytes)?;
    let v = if m.status.status < 0 {
        Err(format!("no fix (status {})", m.status.status))
    } else if !(m.latitude.abs() <= 90.0 && m.longitude.is_finite()) {
        Err(format!("latitude {}°, longitude {}°: not a place", m.latitude, m.longitude))
    } else {
        Ok((m.latitude, m.longitude))
    };
    Ok((m.header.stamp.ns(), v))
}

/// The tilt of the camera at `t_ns`, or why there is none: no sample within
/// `max_gap_s` of the stamp, or the sample needed is unusable.
pub fn tilt_at(
    track: &mut Track<'_, ImuSample>,
    t_ns: i64,
    how: ImuMatch,
    max_gap_s: f64,
) -> Result<Result<Tilt, String>, BagError> {
    let topic = track.topic().to_string();
    let (prev, next) = track.around(t_ns)?;
    let (prev, next) = (prev.cloned(), next.cloned());
    Ok(tilt_between(&topic, prev.as_ref(), next.as_ref(), &|s| track.why(s), t_ns, how, max_gap_s))
}

/// The tilt at `t_ns` from the samples around it (the last at or before, the first
/// after: a [`Track`]'s, or a live node's newest), or why there is none; `why` says
/// why a sample cannot be used, naming where it came from.
pub fn tilt_between(
    topic: &str,
    prev: Option<&Stamped<ImuSample>>,
    next: Option<&Stamped<ImuSample>>,
    why: &dyn Fn(&Stamped<ImuSample>) -> Option<String>,
    t_ns: i64,
    how: ImuMatch,
    max_gap_s: f64,
) -> Result<Tilt, String> {
    let gap_s = |s: &Stamped<ImuSample>| (s.stamp_ns - t_ns).abs() as f64 * 1e-9;
    let usable = |s: Option<&Stamped<ImuSample>>| s.filter(|s| gap_s(s) <= max_gap_s).cloned();
    let (a, b) = (usable(prev), usable(next));
    let pick = match (&a, &b, how) {
        (None, None, _) => {
            return Err(format!("no IMU sample on {topic} within {max_gap_s} s of the image's stamp"));
        }
        (Some(a), Some(b), ImuMatch::Interpolate) => {
            for s in [a, b] {
                if let Some(w) = why(s) {
                    return Err(w);
                }
            }
            let (qa, ra, pa) = a.value.clone().expect("checked");
            let (qb, rb, pb) = b.value.clone().expect("checked");
            let span = (b.stamp_ns - a.stamp_ns) as f64;
            let w = if span > 0.0 { ((t_ns - a.stamp_ns) as f64 / span).clamp(0.0, 1.0) } else { 0.0 };
            let q = DQuat::from_slice(&qa).slerp(DQuat::from_slice(&qb), w);
            return tilt_of([q.x, q.y, q.z, q.w], ra + w * (rb - ra), pa + w * (pb - pa));
        }
        (Some(a), Some(b), ImuMatch::Nearest) => {
            if gap_s(a) <= gap_s(b) {
                a.clone()
            } else {
                b.clone()
            }
        }
        (Some(s), None, _) | (None, Some(s), _) => s.clone(),
    };
    if let Some(w) = why(&pick) {
        return Err(w);
    }
    let (q, r, p) = pick.value.expect("checked");
    tilt_of(q, r, p)
}

/// The place (latitude, longitude) at `t_ns` from the nearest usable fix within
/// `max_age_s`, or why there is none.
pub fn place_at(
    track: &mut Track<'_, (f64, f64)>,
    t_ns: i64,
    max_age_s: f64,
) -> Result<Result<(f64, f64), String>, BagError> {
    let topic = track.topic().to_string();
    let (prev, next) = track.around(t_ns)?;
    let (prev, next) = (prev.cloned(), next.cloned());
    Ok(place_between(&topic, prev.as_ref(), next.as_ref(), &|s| track.why(s), t_ns, max_age_s))
}

/// The place at `t_ns` from the fixes around it, as [`tilt_between`] the tilt.
pub fn place_between(
    topic: &str,
    prev: Option<&Stamped<(f64, f64)>>,
    next: Option<&Stamped<(f64, f64)>>,
    why: &dyn Fn(&Stamped<(f64, f64)>) -> Option<String>,
    t_ns: i64,
    max_age_s: f64,
) -> Result<(f64, f64), String> {
    let mut cands: Vec<&Stamped<(f64, f64)>> = prev.into_iter().chain(next).collect();
    cands.sort_by_key(|s| (s.stamp_ns - t_ns).abs());
    let mut reason = format!("no GNSS fix on {topic} within {max_age_s} s of the image's stamp");
    for s in cands {
        if (s.stamp_ns - t_ns).abs() as f64 * 1e-9 > max_age_s {
            continue;
        }
        match &s.value {
            Ok(p) => return Ok(*p),
            Err(_) => reason = why(s).unwrap_or_default(),
        }
    }
    Err(reason)
}
