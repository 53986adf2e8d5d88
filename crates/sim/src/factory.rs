//! What makes a platoon's controller and its injector in process, from its scenario (its
//! replica, for a fleet): the built-in ones the config names, or the caller's.
use crate::Scenario;
use platoon_attacks::channel::Channel;
use platoon_attacks::inject::{InjectError, Injector};
use platoon_control::Controller;

/// What makes a platoon's controller from its scenario (its replica, for a fleet), in process:
/// [`ControllerFactory::builtin`] builds the one the config names (`platoon_control::build`);
/// [`ControllerFactory::new`] takes the caller's, e.g. a `ComposedController` with a law of
/// its own, for runs and campaigns without a process per cell.
#[derive(Clone)]
pub struct ControllerFactory(std::sync::Arc<MakeController>);

/// The function behind a [`ControllerFactory`].
pub type MakeController =
    dyn Fn(&Scenario) -> Result<Box<dyn Controller>, platoon_control::ParamsError> + Send + Sync;

impl ControllerFactory {
    /// The caller's controllers.
    pub fn new(
        make: impl Fn(&Scenario) -> Result<Box<dyn Controller>, platoon_control::ParamsError>
            + Send
            + Sync
            + 'static,
    ) -> Self {
        Self(std::sync::Arc::new(make))
    }

    /// The controller each scenario's config names.
    pub fn builtin() -> Self {
        Self::new(|s| platoon_control::build(&s.control, &s.topology, &s.initial))
    }

    /// The controller of `scenario`.
    pub fn make(
        &self,
        scenario: &Scenario,
    ) -> Result<Box<dyn Controller>, platoon_control::ParamsError> {
        (self.0)(scenario)
    }
}

impl std::fmt::Debug for ControllerFactory {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("ControllerFactory")
    }
}

/// The same factory (the same function object), not merely an equal one.
impl PartialEq for ControllerFactory {
    fn eq(&self, other: &Self) -> bool {
        std::sync::Arc::ptr_eq(&self.0, &other.0)
    }
}

impl Eq for ControllerFactory {}

/// What makes a platoon's injector from its scenario (its replica, for a fleet), in process:
/// [`InjectorFactory::builtin`] builds the config's channel (DoS schedule, link attacks,
/// radio, jammers); [`InjectorFactory::new`] takes the caller's attack, for runs, campaigns and
/// searches without a process per cell.
#[derive(Clone)]
pub struct InjectorFactory(std::sync::Arc<MakeInjector>);

/// The function behind an [`InjectorFactory`].
pub type MakeInjector = dyn Fn(&Scenario) -> Result<Box<dyn Injector>, InjectError> + Send + Sync;

impl InjectorFactory {
    /// The caller's injectors.
    pub fn new(
        make: impl Fn(&Scenario) -> Result<Box<dyn Injector>, InjectError> + Send + Sync + 'static,
    ) -> Self {
        Self(std::sync::Arc::new(make))
    }

    /// The channel each scenario's config describes.
    pub fn builtin() -> Self {
        Self::new(|s| {
            Ok(Box::new(Channel::new(
                s.channel_spec(),
                s.vehicles_per_platoon(),
            )))
        })
    }

    /// The injector of `scenario`.
    pub fn make(&self, scenario: &Scenario) -> Result<Box<dyn Injector>, InjectError> {
        (self.0)(scenario)
    }
}

impl std::fmt::Debug for InjectorFactory {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("InjectorFactory")
    }
}

/// The same factory (the same function object), not merely an equal one.
impl PartialEq for InjectorFactory {
    fn eq(&self, other: &Self) -> bool {
        std::sync::Arc::ptr_eq(&self.0, &other.0)
    }
}

impl Eq for InjectorFactory {}

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
