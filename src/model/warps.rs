//! (issue 25: being built)
