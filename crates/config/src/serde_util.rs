//! Serde plumbing for the tagged tables: a selector key (`rule`, `kind`, `spacing_policy`, ...)
//! whose value picks the other keys a table may hold, written flat in the table as users write
//! it, held as a typed enum in [`crate::schema::Config`].

use serde::de::{DeserializeOwned, Deserializer};
use serde::ser::{self, Impossible, Serialize, SerializeMap, SerializeStruct};
use std::collections::BTreeSet;
use std::sync::{Mutex, PoisonError};

/// The methods of a `Serializer` that refuses every value but a struct and a unit variant
/// (each serializer here writes those two itself), failing with `$refuse()`.
macro_rules! refuse_the_rest {
    ($refuse:ident) => {
        fn serialize_bool(self, _: bool) -> Result<Self::Ok, Self::Error> {
            Err($refuse())
        }
        fn serialize_i8(self, _: i8) -> Result<Self::Ok, Self::Error> {
            Err($refuse())
        }
        fn serialize_i16(self, _: i16) -> Result<Self::Ok, Self::Error> {
            Err($refuse())
        }
        fn serialize_i32(self, _: i32) -> Result<Self::Ok, Self::Error> {
            Err($refuse())
        }
        fn serialize_i64(self, _: i64) -> Result<Self::Ok, Self::Error> {
            Err($refuse())
        }
        fn serialize_u8(self, _: u8) -> Result<Self::Ok, Self::Error> {
            Err($refuse())
        }
        fn serialize_u16(self, _: u16) -> Result<Self::Ok, Self::Error> {
            Err($refuse())
        }
        fn serialize_u32(self, _: u32) -> Result<Self::Ok, Self::Error> {
            Err($refuse())
        }
        fn serialize_u64(self, _: u64) -> Result<Self::Ok, Self::Error> {
            Err($refuse())
        }
        fn serialize_f32(self, _: f32) -> Result<Self::Ok, Self::Error> {
            Err($refuse())
        }
        fn serialize_f64(self, _: f64) -> Result<Self::Ok, Self::Error> {
            Err($refuse())
        }
        fn serialize_char(self, _: char) -> Result<Self::Ok, Self::Error> {
            Err($refuse())
        }
        fn serialize_str(self, _: &str) -> Result<Self::Ok, Self::Error> {
            Err($refuse())
        }
        fn serialize_bytes(self, _: &[u8]) -> Result<Self::Ok, Self::Error> {
            Err($refuse())
        }
        fn serialize_none(self) -> Result<Self::Ok, Self::Error> {
            Err($refuse())
        }
        fn serialize_some<T: Serialize + ?Sized>(self, _: &T) -> Result<Self::Ok, Self::Error> {
            Err($refuse())
        }
        fn serialize_unit(self) -> Result<Self::Ok, Self::Error> {
            Err($refuse())
        }
        fn serialize_unit_struct(self, _: &'static str) -> Result<Self::Ok, Self::Error> {
            Err($refuse())
        }
        fn serialize_newtype_struct<T: Serialize + ?Sized>(
            self,
            _: &'static str,
            _: &T,
        ) -> Result<Self::Ok, Self::Error> {
            Err($refuse())
        }
        fn serialize_newtype_variant<T: Serialize + ?Sized>(
            self,
            _: &'static str,
            _: u32,
            _: &'static str,
            _: &T,
        ) -> Result<Self::Ok, Self::Error> {
            Err($refuse())
        }
        fn serialize_seq(self, _: Option<usize>) -> Result<Self::SerializeSeq, Self::Error> {
            Err($refuse())
        }
        fn serialize_tuple(self, _: usize) -> Result<Self::SerializeTuple, Self::Error> {
            Err($refuse())
        }
        fn serialize_tuple_struct(
            self,
            _: &'static str,
            _: usize,
        ) -> Result<Self::SerializeTupleStruct, Self::Error> {
            Err($refuse())
        }
        fn serialize_tuple_variant(
            self,
            _: &'static str,
            _: u32,
            _: &'static str,
            _: usize,
        ) -> Result<Self::SerializeTupleVariant, Self::Error> {
            Err($refuse())
        }
        fn serialize_map(self, _: Option<usize>) -> Result<Self::SerializeMap, Self::Error> {
            Err($refuse())
        }
        fn serialize_struct_variant(
            self,
            _: &'static str,
            _: u32,
            _: &'static str,
            _: usize,
        ) -> Result<Self::SerializeStructVariant, Self::Error> {
            Err($refuse())
        }
    };
}

/// An internally tagged enum whose tag may be left out: the table then means [`Self::DEFAULT`].
pub(crate) trait DefaultTag {
    /// The selector key (`spacing_policy`).
    const SELECTOR: &'static str;
    /// The variant an absent selector means (`constant`).
    const DEFAULT: &'static str;
}

/// `#[serde(flatten, deserialize_with = "with_default_tag")]`: the enum of the table's other
/// keys, with [`DefaultTag::DEFAULT`] when the selector is absent.
pub(crate) fn with_default_tag<'de, D, T>(deserializer: D) -> Result<T, D::Error>
where
    D: Deserializer<'de>,
    T: DefaultTag + DeserializeOwned,
{
    let mut table: toml::Table = serde::Deserialize::deserialize(deserializer)?;
    if !table.contains_key(T::SELECTOR) {
        table.insert(T::SELECTOR.into(), T::DEFAULT.into());
    }
    T::deserialize(toml::Value::Table(table))
        .map_err(|e| serde::de::Error::custom(e.message().trim()))
}

/// `#[schemars(transform = default_tag_schema::<T>)]`: the default variant's selector is not
/// required, and the selector's schema says its default.
pub(crate) fn default_tag_schema<T: DefaultTag>(schema: &mut schemars::Schema) {
    let Some(variants) = schema.get_mut("oneOf").and_then(|v| v.as_array_mut()) else {
        return;
    };
    for v in variants {
        let is_default = v
            .pointer(&format!("/properties/{}/const", T::SELECTOR))
            .and_then(|c| c.as_str())
            == Some(T::DEFAULT);
        if !is_default {
            continue;
        }
        if let Some(required) = v.get_mut("required").and_then(|r| r.as_array_mut()) {
            required.retain(|k| k.as_str() != Some(T::SELECTOR));
        }
        if let Some(p) = v.pointer_mut(&format!("/properties/{}", T::SELECTOR)) {
            if let Some(p) = p.as_object_mut() {
                p.insert("default".into(), T::DEFAULT.into());
            }
        }
    }
}

/// Writes the fields of `value` (a struct, or a struct variant of an internally tagged enum) as
/// entries of `map`, leaving out the key `skip` (the tag, written before). The map is a table
/// being written: this is how a tagged table puts its selector first, its common keys next and
/// the variant's keys last, the order its files have always had.
pub(crate) fn entries<M, T>(map: &mut M, value: &T, skip: &'static str) -> Result<(), M::Error>
where
    M: SerializeMap,
    T: Serialize + ?Sized,
{
    value.serialize(Entries { map, skip })
}

struct Entries<'a, M> {
    map: &'a mut M,
    skip: &'static str,
}

impl<M: SerializeMap> SerializeStruct for Entries<'_, M> {
    type Ok = ();
    type Error = M::Error;

    fn serialize_field<T: Serialize + ?Sized>(
        &mut self,
        key: &'static str,
        value: &T,
    ) -> Result<(), M::Error> {
        if key == self.skip {
            Ok(())
        } else {
            self.map.serialize_entry(key, value)
        }
    }

    fn end(self) -> Result<(), M::Error> {
        Ok(())
    }
}

fn not_a_struct<E: ser::Error>() -> E {
    E::custom("a tagged table's variant must be a struct")
}

impl<'a, M: SerializeMap> ser::Serializer for Entries<'a, M> {
    type Ok = ();
    type Error = M::Error;
    type SerializeSeq = Impossible<(), M::Error>;
    type SerializeTuple = Impossible<(), M::Error>;
    type SerializeTupleStruct = Impossible<(), M::Error>;
    type SerializeTupleVariant = Impossible<(), M::Error>;
    type SerializeMap = Impossible<(), M::Error>;
    type SerializeStruct = Self;
    type SerializeStructVariant = Impossible<(), M::Error>;

    fn serialize_struct(
        self,
        _: &'static str,
        _: usize,
    ) -> Result<Self::SerializeStruct, M::Error> {
        Ok(self)
    }

    fn serialize_unit_variant(
        self,
        _: &'static str,
        _: u32,
        _: &'static str,
    ) -> Result<(), M::Error> {
        Err(not_a_struct())
    }

    refuse_the_rest!(not_a_struct);
}

/// The selector's value (`kind`, `rule`, ...) serde writes for a tagged table's enum: the enum's
/// `rename_all` is the one list of its names. Each distinct value is kept for the process's
/// lifetime, once (the enums' names are a finite set), so that it can be handed out as
/// `&'static str` like a literal.
pub(crate) fn tag_name<T: Serialize>(value: &T, selector: &str) -> &'static str {
    static NAMES: Mutex<BTreeSet<&'static str>> = Mutex::new(BTreeSet::new());
    let table = toml::Value::try_from(value).expect("a tagged table serialises");
    let tag = table
        .get(selector)
        .and_then(toml::Value::as_str)
        .expect("a tagged table writes its selector");
    let mut names = NAMES.lock().unwrap_or_else(PoisonError::into_inner);
    if let Some(name) = names.get(tag) {
        return name;
    }
    let name: &'static str = Box::leak(tag.to_owned().into_boxed_str());
    names.insert(name);
    name
}
