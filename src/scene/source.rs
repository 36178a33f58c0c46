//! Locations in a scene file for messages, and the value checks every field shares.

use std::path::Path;

use glam::Vec3;
use toml::Spanned;

use super::{MAX_COLOUR, MAX_COORDINATE, SceneError};

/// Resolves byte spans to `file:line` for messages.
pub(super) struct Source<'a> {
    pub path: &'a Path,
    pub text: &'a str,
}

impl Source<'_> {
    pub(super) fn at<T>(&self, value: &Spanned<T>) -> String {
        let span = value.span();
        if span.end == 0 {
            return self.path.display().to_string();
        }
        let line = self.text[..span.start.min(self.text.len())]
            .matches('\n')
            .count()
            + 1;
        format!("{}:{line}", self.path.display())
    }

    pub(super) fn invalid<T>(
        &self,
        value: &Spanned<T>,
        field: &str,
        reason: impl Into<String>,
    ) -> SceneError {
        SceneError::Invalid {
            file: self.at(value),
            field: field.to_string(),
            reason: reason.into(),
        }
    }

    pub(super) fn finite<const N: usize>(
        &self,
        value: &Spanned<[f32; N]>,
        field: &str,
    ) -> Result<Vec3, SceneError> {
        if let Some(c) = value.get_ref().iter().position(|v| !v.is_finite()) {
            return Err(self.invalid(
                value,
                field,
                format!(
                    "component {c} is {} (numbers must be finite)",
                    value.get_ref()[c]
                ),
            ));
        }
        let v = value.get_ref();
        Ok(Vec3::new(v[0], v[1], *v.get(2).unwrap_or(&0.0)))
    }

    /// A linear RGB colour: finite, each component in `[0, MAX_COLOUR]`.
    pub(super) fn colour(
        &self,
        value: &Spanned<[f32; 3]>,
        field: &str,
    ) -> Result<Vec3, SceneError> {
        let v = self.finite(value, field)?;
        if let Some(c) = (0..3).find(|&c| !(0.0..=MAX_COLOUR).contains(&v[c])) {
            return Err(self.invalid(
                value,
                field,
                format!(
                    "component {c} is {} (linear RGB components lie in [0, {MAX_COLOUR}])",
                    v[c]
                ),
            ));
        }
        Ok(v)
    }

    /// A point: finite, each coordinate within `MAX_COORDINATE`.
    pub(super) fn point(&self, value: &Spanned<[f32; 3]>, field: &str) -> Result<Vec3, SceneError> {
        let v = self.finite(value, field)?;
        if let Some(c) = (0..3).find(|&c| v[c].abs() > MAX_COORDINATE) {
            return Err(self.invalid(
                value,
                field,
                format!(
                    "component {c} is {:e}, beyond the {MAX_COORDINATE:e} (2^60) a coordinate may reach",
                    v[c]
                ),
            ));
        }
        Ok(v)
    }

    pub(super) fn scalar(&self, value: &Spanned<f32>, field: &str) -> Result<f32, SceneError> {
        let v = *value.get_ref();
        if !v.is_finite() {
            return Err(self.invalid(value, field, format!("{v} is not a finite number")));
        }
        Ok(v)
    }
}
