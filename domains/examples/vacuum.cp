% A robot vacuum in three rooms: moving costs 2, sucking 1, calling the cleaners 10.
:- maxAdditive :: 20.
:- sorts room.
:- objects kitchen, hall, study :: room.
:- variables R :: room.
:- constants
  at           :: inertialFluent(room);
  dirty(room)  :: inertialFluent;
  cost         :: additiveFluent(0..20);
  go(room), suck, cleaners :: exogenousAction.

go(R) causes at=R.
nonexecutable go(R) if at=R.
suck causes -dirty(R) if at=R.
cleaners causes -dirty(R).
noconcurrency.
go(R) increments cost by 2.
suck increments cost by 1.
cleaners increments cost by 10.

:- query
  label :: tidy;
  maxstep :: 0..10;
  0: at=hall & dirty(kitchen) & dirty(study) & -dirty(hall) & cost=0;
  maxstep: -dirty(kitchen) & -dirty(study).
