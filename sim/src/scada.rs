//! The simulated tunnel's SCADA: a Modbus TCP server holding the linear heat detector's
//! zones and the ventilation as input registers, laid out by the site file's map
//! ([`firefleet_model::infra`]), as a tunnel's SCADA serves them to other systems.
//!
//! Any Modbus client reads it (the project's tests read it with Python's `pymodbus`); the
//! fleet reads it through `firefleet scada`. Only what the map defines answers: a read
//! touching an unmapped register gets the protocol's "illegal data address" exception,
//! another function "illegal function", another unit identifier "gateway target device
//! failed to respond", as a real device or gateway would.
//!
//! Not here: what the registers hold ([`crate::dts`], [`crate::world::World::vent`]).

use std::future::{Ready, ready};
use std::net::SocketAddr;
use std::sync::{Arc, RwLock};

use firefleet_model::infra::ScadaMap;
use tokio::net::TcpListener;
use tokio_modbus::server::tcp::{Server, accept_tcp_connection};
use tokio_modbus::{ExceptionCode, Request, Response, SlaveRequest};

use crate::world::World;

/// The register image: the DTS block and the ventilation block, each from its first
/// register.
#[derive(Debug, Default)]
struct Image {
    dts: (u32, Vec<u16>),
    vent: (u32, Vec<u16>),
    /// Site time of the DTS measurement it holds.
    measured: Option<f64>,
}

impl Image {
    /// `qty` registers from `addr`, if the map defines every one of them.
    fn read(&self, addr: u16, qty: u16) -> Option<Vec<u16>> {
        let (a, n) = (u32::from(addr), u32::from(qty));
        [&self.dts, &self.vent]
            .into_iter()
            .find_map(|(first, regs)| {
                let from = a.checked_sub(*first)? as usize;
                regs.get(from..from + n as usize).map(<[u16]>::to_vec)
            })
    }
}

/// The registers the server answers from, updated by the simulation loop.
#[derive(Debug, Clone)]
pub struct Registers {
    map: ScadaMap,
    image: Arc<RwLock<Image>>,
}

impl Registers {
    pub fn new(map: ScadaMap) -> Self {
        Self {
            map,
            image: Arc::default(),
        }
    }

    /// Take `world`'s latest DTS measurement and ventilation reading, if the detector
    /// measured since (the loop calls this every step; it measures every `period_s`).
    pub fn update(&self, world: &World) {
        let Some((measured, zones)) = world.dts() else {
            return;
        };
        let image = self.image.read().unwrap_or_else(|p| p.into_inner());
        if image.measured == Some(measured) {
            return;
        }
        drop(image);
        let dts = self.map.encode_dts(zones);
        let vent = self.map.encode_vent(&world.vent());
        let mut image = self.image.write().unwrap_or_else(|p| p.into_inner());
        image.dts = (u32::from(self.map.dts.first_register), dts);
        image.vent = (u32::from(self.map.vent.first_register), vent);
        image.measured = Some(measured);
    }

    fn answer(&self, req: SlaveRequest<'_>) -> Result<Response, ExceptionCode> {
        if req.slave != self.map.unit_id {
            return Err(ExceptionCode::GatewayTargetDevice);
        }
        match req.request {
            Request::ReadInputRegisters(addr, qty) if (1..=125).contains(&qty) => self
                .image
                .read()
                .unwrap_or_else(|p| p.into_inner())
                .read(addr, qty)
                .map(Response::ReadInputRegisters)
                .ok_or(ExceptionCode::IllegalDataAddress),
            Request::ReadInputRegisters(..) => Err(ExceptionCode::IllegalDataValue),
            _ => Err(ExceptionCode::IllegalFunction),
        }
    }
}

/// One client connection's view of the registers.
struct Service(Registers);

impl tokio_modbus::server::Service for Service {
    type Request = SlaveRequest<'static>;
    type Response = Response;
    type Exception = ExceptionCode;
    type Future = Ready<Result<Response, ExceptionCode>>;

    fn call(&self, req: Self::Request) -> Self::Future {
        ready(self.0.answer(req))
    }
}

/// Serve `registers` on `listener` until the task is dropped.
pub async fn serve(listener: TcpListener, registers: Registers) -> std::io::Result<()> {
    let server = Server::new(listener);
    let on_connected = |stream, addr: SocketAddr| {
        let registers = registers.clone();
        async move {
            tracing::info!(client = %addr, "SCADA client connected");
            accept_tcp_connection(stream, addr, move |_| Ok(Some(Service(registers.clone()))))
        }
    };
    server
        .serve(&on_connected, |e| {
            tracing::warn!("SCADA client connection ended: {e}");
        })
        .await
}

#[cfg(test)]
mod tests {
    use super::*;
    use firefleet_model::scenario::Scenario;

    #[test]
    fn only_mapped_registers_of_the_unit_answer() {
        let mut s = Scenario::straight(100.0).build();
        s.scada = Some(toml::from_str("[dts]\nzone_length_m = 10.0\n").unwrap());
        let world = World::new(&s, 1);
        let regs = Registers::new(s.scada.clone().unwrap());
        regs.update(&world);
        let ask = |slave, request| regs.answer(SlaveRequest { slave, request });
        let Ok(Response::ReadInputRegisters(r)) = ask(1, Request::ReadInputRegisters(0, 30)) else {
            panic!("the DTS block answers");
        };
        assert_eq!(r.len(), 30);
        // Ambient, 20.0 C in tenths.
        assert_eq!(r[0], 200);
        assert_eq!(
            ask(1, Request::ReadInputRegisters(0, 31)),
            Err(ExceptionCode::IllegalDataAddress)
        );
        assert_eq!(
            ask(1, Request::ReadInputRegisters(1000, 2)),
            Ok(Response::ReadInputRegisters(vec![0, 0]))
        );
        assert_eq!(
            ask(2, Request::ReadInputRegisters(0, 3)),
            Err(ExceptionCode::GatewayTargetDevice)
        );
        assert_eq!(
            ask(1, Request::ReadHoldingRegisters(0, 3)),
            Err(ExceptionCode::IllegalFunction)
        );
    }
}
