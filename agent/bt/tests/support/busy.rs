// A stateful action that stays Running: the load of the allocation test and the `bt`
// benchmark (included with `include!` by both).

struct Busy;

impl StatefulAction<()> for Busy {
    fn on_start(&mut self, _: &mut Io<'_>, _: &mut ()) -> Status {
        Status::Running
    }
    fn on_running(&mut self, _: &mut Io<'_>, _: &mut ()) -> Status {
        Status::Running
    }
    fn on_halted(&mut self, _: &mut Io<'_>, _: &mut ()) {}
}
