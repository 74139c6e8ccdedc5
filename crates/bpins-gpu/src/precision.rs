//! The kernels' floating-point precision: one WGSL source, two modules.
//!
//! The shaders are written in f64 (`SHADER_F64`), the precision at which rounded DN
//! agree with the CPU pixel for pixel. Many adapters have no f64 (Metal, most
//! integrated and mobile GPUs, wgpu's GL backend) or run it at 1/64 of f32's rate
//! (consumer NVIDIA), so the same source also compiles as f32: every `f64` type becomes
//! `f32` and every `lf` literal an `f` one ([`to_f32`]). Nothing else differs, so the
//! f32 module cannot drift from the f64 one; its agreement with the CPU is statistical
//! (TOLERANCES.md, "f32 GPU path"), checked by the parity tests and `bpins agree`.
//!
//! Shared by `build.rs` (which validates the f32 modules with naga *without* the
//! FLOAT64 capability, so a stray f64 fails the build) and `shaders.rs`.

/// The precision the kernels run at.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum Precision {
    /// f64 throughout the chain and the sums: DN agree with the CPU exactly.
    #[default]
    F64,
    /// f32 throughout (the noise's f32 parts are f32 in both): statistical agreement.
    F32,
}

impl Precision {
    /// "f64" or "f32", as `--gpu-precision` takes it.
    pub fn name(self) -> &'static str {
        match self {
            Precision::F64 => "f64",
            Precision::F32 => "f32",
        }
    }

    /// Bytes of one float of the kernels' sums.
    pub fn float_bytes(self) -> u64 {
        match self {
            Precision::F64 => 8,
            Precision::F32 => 4,
        }
    }

    /// The WGSL source at this precision.
    pub fn source(self, f64_source: &str) -> String {
        match self {
            Precision::F64 => f64_source.to_string(),
            Precision::F32 => to_f32(f64_source),
        }
    }
}

impl std::str::FromStr for Precision {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "f64" => Ok(Precision::F64),
            "f32" => Ok(Precision::F32),
            _ => Err(format!("precision `{s}`: expected f64 or f32")),
        }
    }
}

/// The f32 twin of an f64 WGSL source: the type name `f64` (a whole token) becomes
/// `f32`, a numeric literal's `lf` suffix becomes `f`. Identifiers that merely contain
/// "f64" (`sin_cos_f64`) and comments keep their text but not their meaning.
pub fn to_f32(src: &str) -> String {
    let b = src.as_bytes();
    let mut out = String::with_capacity(src.len());
    let mut i = 0;
    while i < b.len() {
        let c = b[i];
        if c == b'/' && b.get(i + 1) == Some(&b'/') {
            // A line comment, kept as it is.
            let end = src[i..].find('\n').map_or(b.len(), |n| i + n);
            out.push_str(&src[i..end]);
            i = end;
        } else if c.is_ascii_alphabetic() || c == b'_' {
            let end = i + b[i..].iter().take_while(|x| x.is_ascii_alphanumeric() || **x == b'_').count();
            out.push_str(if &src[i..end] == "f64" { "f32" } else { &src[i..end] });
            i = end;
        } else if c.is_ascii_digit() || (c == b'.' && b.get(i + 1).is_some_and(u8::is_ascii_digit)) {
            // A numeric literal: digits, '.', hex digits, an exponent with its sign, suffix.
            let mut end = i;
            while end < b.len() {
                let x = b[end];
                let signed_exp =
                    (x == b'+' || x == b'-') && matches!(b[end - 1], b'e' | b'E') && !src[i..end].starts_with("0x");
                if x.is_ascii_alphanumeric() || x == b'.' || signed_exp {
                    end += 1;
                } else {
                    break;
                }
            }
            let lit = &src[i..end];
            match lit.strip_suffix("lf") {
                Some(body) => {
                    out.push_str(body);
                    out.push('f');
                }
                None => out.push_str(lit),
            }
            i = end;
        } else {
            // Any other character, whole (the sources' comments hold non-ASCII text).
            let ch = src[i..].chars().next().expect("a character at a char boundary");
            out.push(ch);
            i += ch.len_utf8();
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn types_and_literals_become_f32_and_nothing_else_changes() {
        let src =
            "fn sin_cos_f64(x: f64) -> vec2<f64> { let a = 1.5lf * 2e-3lf + f64(3u) + 0x1fu + 1e5; }\n// f64 here\n";
        assert_eq!(
            to_f32(src),
            "fn sin_cos_f64(x: f32) -> vec2<f32> { let a = 1.5f * 2e-3f + f32(3u) + 0x1fu + 1e5; }\n// f64 here\n"
        );
        assert_eq!(Precision::F64.source(src), src);
        assert_eq!("f32".parse::<Precision>(), Ok(Precision::F32));
        assert!("f16".parse::<Precision>().is_err());
    }
}
