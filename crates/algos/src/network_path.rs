//! Where an off-policy learner's networks compute: Burn modules with autodiff, or the
//! host MLP path (`backend = "host"`, issue 51). SAC and TD3 each hold an [`OnPath`] of
//! their two network sets; either set reads and writes the same [`HoldsModules::Modules`]
//! (the networks as files hold them).

/// A set of networks that reads and writes its modules.
pub trait HoldsModules {
    /// The networks as Burn modules (files, acting, tests).
    type Modules;

    /// A copy of the networks as modules.
    fn modules(&self) -> Self::Modules;
    /// The networks replaced by `modules`' (the optimisers kept); an error says what the
    /// set cannot compute.
    fn set_modules(&mut self, modules: Self::Modules) -> Result<(), String>;
}

/// A learner's networks on one of the two paths.
pub enum OnPath<B, H> {
    /// Burn modules, gradients by autodiff (any backend, image observations).
    Burn(Box<B>),
    /// The host MLP path.
    Host(Box<H>),
}

impl<B: HoldsModules, H: HoldsModules<Modules = B::Modules>> OnPath<B, H> {
    /// The networks as modules.
    pub fn modules(&self) -> B::Modules {
        match self {
            Self::Burn(burn) => burn.modules(),
            Self::Host(host) => host.modules(),
        }
    }

    /// The networks replaced by `modules`' (the optimisers kept).
    pub fn set_modules(&mut self, modules: B::Modules) -> Result<(), String> {
        match self {
            Self::Burn(burn) => burn.set_modules(modules),
            Self::Host(host) => host.set_modules(modules),
        }
    }

    /// Moves Burn networks to the host path, built by `host` from their modules (fresh
    /// optimisers); nothing when already there.
    pub fn to_host(
        &mut self,
        host: impl FnOnce(B::Modules) -> Result<H, String>,
    ) -> Result<(), String> {
        if let Self::Burn(burn) = self {
            *self = Self::Host(Box::new(host(burn.modules())?));
        }
        Ok(())
    }
}
