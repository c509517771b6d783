// Code in mod.rs that calls a child which imports mod.rs back.
mod draw;

pub struct Scene;

impl Scene {
    pub fn write(&self) {
        draw::Logger.scene(self);
    }
}
