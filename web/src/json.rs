//! Reading the bridge's JSON into the app's types with less code: [`from_str`] is
//! `serde_json::from_str` for answers whose structs are always JSON objects.
//!
//! Serde's derived reading of a struct accepts it as an object or as an array of its
//! fields, and `serde_json` instantiates both for every struct the app reads (some
//! 35 of them). The bridge only ever writes objects, so [`from_str`] reads through
//! [`Objects`], a thin wrapper around `serde_json`'s deserializer that asks for a
//! map wherever a struct is wanted: the array reading of every struct is then never
//! used and the compiler leaves it out of the app. Everything else (strings, numbers,
//! lists, options, enums) reads exactly as with `serde_json`.

use std::fmt;

use serde::de::{
    self, DeserializeOwned, DeserializeSeed, Deserializer, EnumAccess, MapAccess, SeqAccess,
    VariantAccess, Visitor,
};

/// `serde_json::from_str`, with structs read as JSON objects only.
///
/// # Errors
/// As `serde_json::from_str`; a struct written as an array is an error too.
pub fn from_str<T: DeserializeOwned>(text: &str) -> Result<T, serde_json::Error> {
    let mut json = serde_json::Deserializer::from_str(text);
    let value = T::deserialize(Objects(&mut json))?;
    json.end()?;
    Ok(value)
}

/// A deserializer that reads structs as maps and hands every nested value on
/// wrapped the same way.
struct Objects<D>(D);

/// A visitor whose nested deserializers are wrapped in [`Objects`].
struct Wrap<V>(V);

/// Passes every method `$method(args…, visitor)` on to the wrapped deserializer
/// with the visitor wrapped.
macro_rules! forward {
    ($($method:ident($($arg:ident: $ty:ty),*);)*) => {$(
        fn $method<V: Visitor<'de>>(self, $($arg: $ty,)* visitor: V) -> Result<V::Value, D::Error> {
            self.0.$method($($arg,)* Wrap(visitor))
        }
    )*};
}

impl<'de, D: Deserializer<'de>> Deserializer<'de> for Objects<D> {
    type Error = D::Error;

    forward! {
        deserialize_any();
        deserialize_bool();
        deserialize_i8();
        deserialize_i16();
        deserialize_i32();
        deserialize_i64();
        deserialize_i128();
        deserialize_u8();
        deserialize_u16();
        deserialize_u32();
        deserialize_u64();
        deserialize_u128();
        deserialize_f32();
        deserialize_f64();
        deserialize_char();
        deserialize_str();
        deserialize_string();
        deserialize_bytes();
        deserialize_byte_buf();
        deserialize_option();
        deserialize_unit();
        deserialize_unit_struct(name: &'static str);
        deserialize_newtype_struct(name: &'static str);
        deserialize_seq();
        deserialize_tuple(len: usize);
        deserialize_tuple_struct(name: &'static str, len: usize);
        deserialize_map();
        deserialize_enum(name: &'static str, variants: &'static [&'static str]);
        deserialize_identifier();
        deserialize_ignored_any();
    }

    fn deserialize_struct<V: Visitor<'de>>(
        self,
        _name: &'static str,
        _fields: &'static [&'static str],
        visitor: V,
    ) -> Result<V::Value, D::Error> {
        self.0.deserialize_map(Wrap(visitor))
    }
}

/// Passes every `visit_…(value)` of a plain value on to the wrapped visitor.
macro_rules! visit {
    ($($method:ident($ty:ty);)*) => {$(
        fn $method<E: de::Error>(self, value: $ty) -> Result<V::Value, E> {
            self.0.$method(value)
        }
    )*};
}

impl<'de, V: Visitor<'de>> Visitor<'de> for Wrap<V> {
    type Value = V::Value;

    fn expecting(&self, formatter: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.0.expecting(formatter)
    }

    visit! {
        visit_bool(bool);
        visit_i64(i64);
        visit_i128(i128);
        visit_u64(u64);
        visit_u128(u128);
        visit_f64(f64);
        visit_char(char);
        visit_str(&str);
        visit_borrowed_str(&'de str);
        visit_string(String);
        visit_bytes(&[u8]);
        visit_borrowed_bytes(&'de [u8]);
        visit_byte_buf(Vec<u8>);
    }

    fn visit_none<E: de::Error>(self) -> Result<V::Value, E> {
        self.0.visit_none()
    }

    fn visit_unit<E: de::Error>(self) -> Result<V::Value, E> {
        self.0.visit_unit()
    }

    fn visit_some<D: Deserializer<'de>>(self, value: D) -> Result<V::Value, D::Error> {
        self.0.visit_some(Objects(value))
    }

    fn visit_newtype_struct<D: Deserializer<'de>>(self, value: D) -> Result<V::Value, D::Error> {
        self.0.visit_newtype_struct(Objects(value))
    }

    fn visit_seq<A: SeqAccess<'de>>(self, seq: A) -> Result<V::Value, A::Error> {
        self.0.visit_seq(Wrap(seq))
    }

    fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<V::Value, A::Error> {
        self.0.visit_map(Wrap(map))
    }

    fn visit_enum<A: EnumAccess<'de>>(self, data: A) -> Result<V::Value, A::Error> {
        self.0.visit_enum(Wrap(data))
    }
}

impl<'de, S: DeserializeSeed<'de>> DeserializeSeed<'de> for Wrap<S> {
    type Value = S::Value;

    fn deserialize<D: Deserializer<'de>>(self, deserializer: D) -> Result<S::Value, D::Error> {
        self.0.deserialize(Objects(deserializer))
    }
}

impl<'de, A: SeqAccess<'de>> SeqAccess<'de> for Wrap<A> {
    type Error = A::Error;

    fn next_element_seed<T: DeserializeSeed<'de>>(
        &mut self,
        seed: T,
    ) -> Result<Option<T::Value>, A::Error> {
        self.0.next_element_seed(Wrap(seed))
    }

    fn size_hint(&self) -> Option<usize> {
        self.0.size_hint()
    }
}

impl<'de, A: MapAccess<'de>> MapAccess<'de> for Wrap<A> {
    type Error = A::Error;

    fn next_key_seed<K: DeserializeSeed<'de>>(
        &mut self,
        seed: K,
    ) -> Result<Option<K::Value>, A::Error> {
        self.0.next_key_seed(Wrap(seed))
    }

    fn next_value_seed<T: DeserializeSeed<'de>>(&mut self, seed: T) -> Result<T::Value, A::Error> {
        self.0.next_value_seed(Wrap(seed))
    }

    fn size_hint(&self) -> Option<usize> {
        self.0.size_hint()
    }
}

impl<'de, A: EnumAccess<'de>> EnumAccess<'de> for Wrap<A> {
    type Error = A::Error;
    type Variant = Wrap<A::Variant>;

    fn variant_seed<T: DeserializeSeed<'de>>(
        self,
        seed: T,
    ) -> Result<(T::Value, Self::Variant), A::Error> {
        let (value, variant) = self.0.variant_seed(Wrap(seed))?;
        Ok((value, Wrap(variant)))
    }
}

impl<'de, A: VariantAccess<'de>> VariantAccess<'de> for Wrap<A> {
    type Error = A::Error;

    fn unit_variant(self) -> Result<(), A::Error> {
        self.0.unit_variant()
    }

    fn newtype_variant_seed<T: DeserializeSeed<'de>>(self, seed: T) -> Result<T::Value, A::Error> {
        self.0.newtype_variant_seed(Wrap(seed))
    }

    fn tuple_variant<V: Visitor<'de>>(self, len: usize, visitor: V) -> Result<V::Value, A::Error> {
        self.0.tuple_variant(len, Wrap(visitor))
    }

    fn struct_variant<V: Visitor<'de>>(
        self,
        fields: &'static [&'static str],
        visitor: V,
    ) -> Result<V::Value, A::Error> {
        self.0.struct_variant(fields, Wrap(visitor))
    }
}

#[cfg(test)]
mod tests {
    use wasm_bindgen_test::wasm_bindgen_test;

    use floatball_shared::api::{ApiError, InstallationInfo, PlanReport, Playlist, Status};

    use super::*;

    /// The app's answers read as `serde_json` reads them.
    #[wasm_bindgen_test(unsupported = test)]
    fn answers_read_as_with_serde_json() {
        let texts = [
            r#"{"state":"playing","entry":0,"show":"wave","show_time_ms":1500,"show_duration_ms":8000,"cycle":1,"progress":0.2,
                "gateways":[{"kind":"scl","port":"/dev/ttyUSB0","link":"not_answering","bytes_per_s":1.5,"baud":9600,
                "drives":[],"health":{"expected":2,"answering":1,"missing":[7]}}],"armed":{"entry":0,"show":"w","progress":1.0}}"#,
        ];
        for text in texts {
            let ours: Status = from_str(text).expect(text);
            let theirs: Status = serde_json::from_str(text).expect(text);
            assert_eq!(ours, theirs);
        }
        let error = r#"{"error":"no","code":"x","params":{"a":"1"},"details":["d"],"problems":[{"code":"y"}]}"#;
        assert_eq!(
            from_str::<ApiError>(error).expect("error"),
            serde_json::from_str::<ApiError>(error).expect("error")
        );
        let playlist = r#"{"entries":[{"show":"a","delay_ms":0,"cycles":1}],"loop_playlist":true}"#;
        assert_eq!(
            from_str::<Playlist>(playlist).ok(),
            serde_json::from_str::<Playlist>(playlist).ok()
        );
        let installation = r#"{"rows":1,"cols":2,"pitch_mm":500.0,"travel_mm":7500.0,"max_speed_mm_s":2000.0,
            "max_accel_mm_s2":4000.0,"home_mm":0.0,"approach_speed_mm_s":250.0,"counts_per_mm":100.0,
            "gateways":[{"kind":"mbox","port":"sim","stations":[1,2]}]}"#;
        assert_eq!(
            from_str::<InstallationInfo>(installation).expect("installation"),
            serde_json::from_str::<InstallationInfo>(installation).expect("installation")
        );
        let report = r#"{"show":"x","feasible":true,"fixes":[],"gateways":[],"preload_ms":5}"#;
        assert_eq!(
            from_str::<PlanReport>(report).expect("report"),
            serde_json::from_str::<PlanReport>(report).expect("report")
        );
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn structs_as_arrays_and_trailing_text_are_refused() {
        assert!(from_str::<ApiError>(r#"["no", "x"]"#).is_err());
        assert!(serde_json::from_str::<ApiError>(r#"["no", "x"]"#).is_ok());
        assert!(from_str::<ApiError>(r#"{"error":"no"} x"#).is_err());
        assert!(from_str::<Vec<u8>>("[1, 2]").is_ok_and(|list| list == [1, 2]));
    }
}
