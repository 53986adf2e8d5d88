//! What makes a platoon's controller and its injector in process, from its scenario (its
//! replica, for a fleet): the built-in ones the config names, or the caller's.
use crate::Scenario;
use platoon_attacks::channel::Channel;
use platoon_attacks::inject::{InjectError, Injector};
use platoon_control::Controller;

/// What makes one part `P` of a platoon (its controller or its injector) from its scenario (its
/// replica, for a fleet), in process: a function shared by every clone. [`ControllerFactory`]
/// and [`InjectorFactory`] name the two.
pub struct Factory<P: ?Sized, E>(std::sync::Arc<Make<P, E>>);

/// The function behind a [`Factory`].
pub type Make<P, E> = dyn Fn(&Scenario) -> Result<Box<P>, E> + Send + Sync;

/// What makes a platoon's controller from its scenario (its replica, for a fleet), in process:
/// [`ControllerFactory::builtin`] builds the one the config names (`platoon_control::build`);
/// [`ControllerFactory::new`] takes the caller's, e.g. a `ComposedController` with a law of
/// its own, for runs and campaigns without a process per cell.
pub type ControllerFactory = Factory<dyn Controller, platoon_control::ParamsError>;

/// The function behind a [`ControllerFactory`].
pub type MakeController = Make<dyn Controller, platoon_control::ParamsError>;

/// What makes a platoon's injector from its scenario (its replica, for a fleet), in process:
/// [`InjectorFactory::builtin`] builds the config's channel (DoS schedule, link attacks,
/// radio, jammers); [`InjectorFactory::new`] takes the caller's attack, for runs, campaigns and
/// searches without a process per cell.
pub type InjectorFactory = Factory<dyn Injector, InjectError>;

/// The function behind an [`InjectorFactory`].
pub type MakeInjector = Make<dyn Injector, InjectError>;

impl<P: ?Sized, E> Factory<P, E> {
    /// The caller's function.
    pub fn new(make: impl Fn(&Scenario) -> Result<Box<P>, E> + Send + Sync + 'static) -> Self {
        Self(std::sync::Arc::new(make))
    }

    /// The part of `scenario`.
    pub fn make(&self, scenario: &Scenario) -> Result<Box<P>, E> {
        (self.0)(scenario)
    }
}

impl ControllerFactory {
    /// The controller each scenario's config names.
    pub fn builtin() -> Self {
        Self::new(|s| platoon_control::build(&s.control, &s.topology, &s.initial))
    }
}

impl InjectorFactory {
    /// The channel each scenario's config describes.
    pub fn builtin() -> Self {
        Self::new(|s| {
            Ok(Box::new(Channel::new(
                s.channel_spec(),
                s.vehicles_per_platoon(),
            )))
        })
    }
}

impl<P: ?Sized, E> Clone for Factory<P, E> {
    fn clone(&self) -> Self {
        Self(self.0.clone())
    }
}

impl<P: ?Sized, E> std::fmt::Debug for Factory<P, E> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Factory")
    }
}

/// The same factory (the same function object), not merely an equal one.
impl<P: ?Sized, E> PartialEq for Factory<P, E> {
    fn eq(&self, other: &Self) -> bool {
        std::sync::Arc::ptr_eq(&self.0, &other.0)
    }
}

impl<P: ?Sized, E> Eq for Factory<P, E> {}

/// What an in-process run plugs in: its controllers and its injectors (by default the
/// built-in ones the config names).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Plugins {
    /// Makes each platoon's controller.
    pub controller: ControllerFactory,
    /// Makes each platoon's injector.
    pub injector: InjectorFactory,
}

impl Default for Plugins {
    fn default() -> Self {
        Self {
            controller: ControllerFactory::builtin(),
            injector: InjectorFactory::builtin(),
        }
    }
}
