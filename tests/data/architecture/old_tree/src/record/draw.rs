use super::Scene;

pub(crate) struct Logger;

impl Logger {
    pub(crate) fn scene(&self, _scene: &Scene) {}
}
