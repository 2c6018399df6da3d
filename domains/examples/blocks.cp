% Blocks on a table, moved one at a time by a crane that charges for every move: an additive
% cost fluent with a bound.  `cplus plan blocks.cp` finds the shortest plan within the budget.

:- maxAdditive :: 6.

:- sorts
  location >> block.

:- objects
  a, b, c     :: block;
  table       :: location.

:- variables
  B, B1       :: block;
  L           :: location;
  N           :: 0..6.

:- constants
  loc(block)          :: inertialFluent(location);
  cost                :: additiveFluent(0..6);
  move(block)         :: exogenousAction;
  to(block)           :: attribute(location) of move(block).

move(B) causes loc(B)=L if to(B)=L.
nonexecutable move(B) if loc(B1)=B.                   % only a clear block moves
nonexecutable move(B) if to(B)=B.                     % not onto itself
nonexecutable move(B) if to(B)=B1 & loc(B)=B1.        % a move changes something
nonexecutable move(B) & move(B1) where B @< B1.       % one crane
constraint loc(B)=loc(B1) ->> loc(B)=table where B @< B1.
nonexecutable move(B) if to(B)=L & loc(B1)=L & L\=table.

move(B) increments cost by 2.

:- show loc(B); cost; move(B); to(B)=L.

% Reverse the tower c-on-b-on-a within a budget of 6.
:- query
  maxstep :: 0..10;
  0: loc(c)=b & loc(b)=a & loc(a)=table & cost=0;
  maxstep: loc(a)=b & loc(b)=c & loc(c)=table & [\/N | cost=N & N =< 6].
