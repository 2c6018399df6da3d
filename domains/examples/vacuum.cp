% A robot vacuum in three rooms; moving costs 2, cleaning costs 1.
:- maxAdditive :: 20.
:- sorts room.
:- objects kitchen, hall, study :: room.
:- variables R :: room.
:- constants
  at           :: inertialFluent(room);
  dirty(room)  :: inertialFluent;
  cost         :: additiveFluent(0..20);
  go(room)     :: exogenousAction;
  suck         :: exogenousAction.

go(R) causes at=R.
nonexecutable go(R) if at=R.
suck causes -dirty(R) if at=R.
nonexecutable go(R) & suck.
go(R) increments cost by 2.
suck increments cost by 1.

:- query
  label :: tidy;
  maxstep :: 0..10;
  0: at=hall & dirty(kitchen) & dirty(study) & -dirty(hall) & cost=0;
  maxstep: -dirty(kitchen) & -dirty(study).
