//! The observer copies of the step streams, for read-only observers.
use super::*;

/// One observer copy (a mirror of a step stream): its service and the outlet that publishes on it.
type Mirror<T> = (crate::ipc::StepService<T>, crate::ipc::Outlet<T>);

/// The observer copies of the four step streams (`observe/<leaf>`), published only while
/// someone subscribes.
pub(super) struct Observe {
    states: Mirror<VehicleState>,
    tx: Mirror<LinkPacket>,
    rx: Mirror<LinkPacket>,
    commands: Mirror<Command>,
}

impl Observe {
    pub(super) fn create(
        e: &Endpoint,
        observers: usize,
        scenario: &Scenario,
    ) -> Result<Self, CosimError> {
        let vehicles = Numbering::of(scenario).vehicles();
        macro_rules! stream {
            ($o:expr, $len:expr) => {{
                let service = e.create_observe_service($o, observers)?;
                let outlet = e.outlet(&service, Service::Observe($o), $len)?;
                (service, outlet)
            }};
        }
        Ok(Self {
            states: stream!(Observed::States, vehicles),
            tx: stream!(Observed::Tx, vehicles * 4),
            rx: stream!(Observed::Rx, vehicles * 4),
            commands: stream!(Observed::Commands, vehicles),
        })
    }

    pub(super) fn publish(
        &self,
        k: u64,
        dt: f64,
        s: &[VehicleState],
        t: &[LinkPacket],
        r: &[LinkPacket],
        c: &[Command],
    ) -> Result<(), CosimError> {
        use iceoryx2::service::port_factory::PortFactory as _;
        fn one<T: std::fmt::Debug + Copy + iceoryx2::prelude::ZeroCopySend + 'static>(
            (service, outlet): &Mirror<T>,
            k: u64,
            dt: f64,
            items: &[T],
        ) -> Result<(), CosimError> {
            if service.dynamic_config().number_of_subscribers() > 0 {
                outlet.send(k, dt, items)?;
            }
            Ok(())
        }
        one(&self.states, k, dt, s)?;
        one(&self.tx, k, dt, t)?;
        one(&self.rx, k, dt, r)?;
        one(&self.commands, k, dt, c)
    }
}
