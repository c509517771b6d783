mod markers;

pub(crate) use markers::MarkerLevel;
