//! Flags whose values are the library's own enums, parsed by the names the library
//! gives them (`ALL`, `name()`): the CLI keeps no copy of an enum of the core.

use clap::builder::{PossibleValuesParser, TypedValueParser};

/// A parser of `--flag NAME` into the variant of `all` whose `name` is NAME; the help
/// and the error list every name.
pub fn by_name<T: Copy + Send + Sync + 'static>(
    all: &'static [T],
    name: fn(T) -> &'static str,
) -> impl TypedValueParser<Value = T> {
    PossibleValuesParser::new(all.iter().map(|&v| name(v)))
        .map(move |s: String| *all.iter().find(|&&v| name(v) == s).expect("a possible value is a name"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use bpins_core::camera::Projection;
    use clap::Parser;

    #[derive(Parser)]
    struct Cli {
        #[arg(long, value_parser = by_name(&Projection::ALL, Projection::name), default_value = "pinhole")]
        projection: Projection,
    }

    #[test]
    fn every_name_parses_to_its_variant_and_others_are_refused() {
        for p in Projection::ALL {
            assert_eq!(Cli::try_parse_from(["x", "--projection", p.name()]).unwrap().projection, p);
        }
        assert_eq!(Cli::try_parse_from(["x"]).unwrap().projection, Projection::Pinhole);
        let e = Cli::try_parse_from(["x", "--projection", "fisheye"]).err().unwrap().to_string();
        assert!(e.contains("equidistant") && e.contains("stereographic"), "{e}");
    }
}
