//! Arguments that take one of a type's names: the list comes from the type, so `--help`,
//! completion and clap's errors name exactly what the library accepts.
use clap::builder::{PossibleValuesParser, TypedValueParser};

/// A parser for one of `all`, each known by `name`.
pub(crate) fn one_of<T: Copy + Send + Sync + 'static>(
    all: &'static [T],
    name: fn(T) -> &'static str,
) -> impl TypedValueParser<Value = T> {
    PossibleValuesParser::new(all.iter().map(|&t| name(t))).map(move |s| {
        *all.iter()
            .find(|&&t| name(t) == s)
            .expect("clap accepts only the names of `all`")
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use platoon_config::LawName;

    #[derive(Debug, clap::Parser)]
    struct Laws {
        #[arg(long, value_delimiter = ',', value_parser = one_of(&LawName::ALL, LawName::name))]
        laws: Vec<LawName>,
    }

    #[test]
    fn names_parse_into_the_type_and_others_are_refused_with_the_list() {
        use clap::Parser;
        let l = Laws::try_parse_from(["x", "--laws", "ploeg,paper"]).unwrap();
        assert_eq!(l.laws, vec![LawName::Ploeg, LawName::Paper]);
        let e = Laws::try_parse_from(["x", "--laws", "pid"])
            .unwrap_err()
            .to_string();
        let names: Vec<_> = LawName::ALL.map(LawName::name).into();
        assert!(e.contains(&names.join(", ")), "{e}");
    }
}
