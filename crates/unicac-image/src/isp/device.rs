//! The steps of [`super::Pipeline::process`] another device (a GPU) can take over, each with the
//! contract of the CPU function it replaces. A device returns None to leave a step to the CPU (too small
//! a job, no adapter, a sensor beyond its limits): a simulation never fails for want of a device.
//! Defined here, implemented by unicac-gpu, chosen by the faces (`--device`).

use super::bayer::Demosaic;
use super::noise::SensorNoise;
use super::white_balance::WhiteBalanceGains;
use crate::Planar;

pub trait IspDevice: Sync {
    /// [`super::read_out`]`(exposure, sensor, Some(noise_seed))`: the same counter streams, the
    /// device's own precision.
    fn read_out(&self, _exposure: &Planar, _sensor: &SensorNoise, _noise_seed: u64) -> Option<Planar> {
        None
    }

    /// [`super::demosaic`] of [`super::apply_white_balance_mosaic`] of [`super::subtract_black_level`]
    /// of the raw mosaic `dn`: the linear RGB image before clipping and the output encoding.
    fn develop(
        &self,
        _dn: &Planar,
        _sensor: &SensorNoise,
        _gains: WhiteBalanceGains,
        _method: Demosaic,
    ) -> Option<Planar> {
        None
    }
}

/// Every step on the CPU.
pub struct HostIsp;

impl IspDevice for HostIsp {}
