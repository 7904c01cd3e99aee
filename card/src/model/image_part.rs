//! A command language's own part of the saved image: the fields it adds beside the PMAC part
//! of format 2 (a Power card's buffer texts, M-variables and setup elements). The language
//! installs [`ImageHooks`] with its extension (`ExtVars::image_hooks`); the image code writes
//! and reads the part without knowing its fields, so the PMAC dialect does not name another
//! dialect's types.

use serde::{Deserialize, Deserializer, Serialize, Serializer};

use super::CardModel;

/// The language's fields of the image, in the order they are written (JSON values).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ImagePart(pub Vec<(String, serde_json::Value)>);

impl ImagePart {
    /// The value of field `name`, if the image has it.
    pub fn get(&self, name: &str) -> Option<&serde_json::Value> {
        self.0.iter().find(|(k, _)| k == name).map(|(_, v)| v)
    }
}

impl Serialize for ImagePart {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_map(self.0.iter().map(|(k, v)| (k, v)))
    }
}

impl<'de> Deserialize<'de> for ImagePart {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let m = serde_json::Map::<String, serde_json::Value>::deserialize(d)?;
        Ok(ImagePart(m.into_iter().collect()))
    }
}

/// How the language's part is restored.
#[derive(Debug, Clone, PartialEq)]
pub enum PartLoad {
    /// No image at all: the language's factory state.
    Factory,
    /// `$$$***`: buffers erased and setup at factory values; what the reset keeps stays.
    Reinit,
    /// A loaded image's part (empty for an image written without one).
    Image(ImagePart),
}

/// The language's save hooks.
#[derive(Debug, Clone, Copy)]
pub struct ImageHooks {
    /// The part to write for `card`.
    pub export: fn(&CardModel) -> ImagePart,
    /// Restore the part into `card`.
    pub load: fn(&mut CardModel, PartLoad),
}

impl CardModel {
    fn image_hooks(&self) -> Option<ImageHooks> {
        self.ext.as_ref()?.image_hooks()
    }

    /// The installed language's part of the image (empty when it has none).
    pub fn export_image_part(&self) -> ImagePart {
        self.image_hooks()
            .map(|h| (h.export)(self))
            .unwrap_or_default()
    }

    /// Restore the installed language's part (nothing when it has none).
    pub fn load_image_part(&mut self, how: PartLoad) {
        if let Some(h) = self.image_hooks() {
            (h.load)(self, how);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_part_keeps_its_field_order_and_reads_back() {
        let p = ImagePart(vec![
            ("sources".into(), serde_json::json!([1])),
            ("mvars".into(), serde_json::json!({"a": 2})),
            ("elems".into(), serde_json::json!([])),
        ]);
        let text = serde_json::to_string(&p).unwrap();
        assert_eq!(text, r#"{"sources":[1],"mvars":{"a":2},"elems":[]}"#);
        let back: ImagePart = serde_json::from_str(&text).unwrap();
        assert_eq!(back.get("mvars"), Some(&serde_json::json!({"a": 2})));
        assert_eq!(back.get("other"), None);
    }
}
