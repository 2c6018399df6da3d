% A pendulum that swings every step unless it is held: the second worked example of the
% language reference (D.6).  From 0: -s with maxstep 2 there are exactly four histories.

:- constants
  s       :: simpleFluent;     % the pendulum is on the right
  h       :: exogenousAction.  % hold it for one step

default s after -s.
default -s after s.
h causes s if s.
h causes -s if -s.

:- query
  maxstep :: 2;
  0: -s.
