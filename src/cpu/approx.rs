//! The thesis's approximate criteria (fragment path options); see [`super`] for the exact one.
