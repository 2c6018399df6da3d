% The mail robot of ROSoClingo's case study (Andres et al., "ROSoClingo: a ROS package for
% ASP-based robot control"), in C+: offices in a corridor, a robot that moves between the
% offices, picks up mail packages and delivers them, carrying up to `capacity` at a time.
% Requests and cancellations are events.
%
% Include it after declaring the sort `office` and its objects, and the macros `capacity`
% (packages on board at most) and `slots` (requests in flight at most); then say how the
% robot moves between offices (moves.cp: from office to office; line.cp: along a line).
% Which actions are the robot's and which are events is not said here: `cplus serve` takes
% the events of requests and cancellations from requests.toml, the rest are the robot's.

:- sorts
  package; phase.

:- objects
  1..slots                     :: package;
  idle, waiting, carried       :: phase.

:- variables
  O, O1                        :: office;
  P, P1                        :: package;
  N                            :: 0..capacity.

:- constants
  at                           :: inertialFluent(office);    % where the robot is
  phase(package)               :: inertialFluent(phase);     % idle: no request in flight
  origin(package)              :: inertialFluent(office*);   % where it is to be picked up
  dest(package)                :: inertialFluent(office*);   % where it is to be delivered
  load                         :: inertialFluent(0..capacity);
  pending(package)             :: sdFluent;                  % the request is not done yet
  % the robot's actions (how it moves is up to the file that includes this one)
  pickup(package)              :: exogenousAction;
  deliver(package)             :: exogenousAction;
  % events: a request to deliver package P from office O (request(P,O) and address(P,O1)
  % arrive together) to office O1; its cancellation
  request(package, office)     :: exogenousAction;
  address(package, office)     :: exogenousAction;
  cancel(package)              :: exogenousAction.

caused pending(P) if -(phase(P)=idle).
default -pending(P).

% Picking up at the origin, delivering at the destination, at most `capacity` on board.
pickup(P) causes phase(P)=carried.
pickup(P) causes load=N+1 if load=N where N < capacity.
nonexecutable pickup(P) if -(phase(P)=waiting).
nonexecutable pickup(P) if origin(P)=O & -(at=O).
nonexecutable pickup(P) if load=capacity.

deliver(P) causes phase(P)=idle & origin(P)=none & dest(P)=none.
deliver(P) causes load=N-1 if load=N where N > 0.
nonexecutable deliver(P) if -(phase(P)=carried).
nonexecutable deliver(P) if dest(P)=O & -(at=O).

% One action at a time.
nonexecutable pickup(P) & pickup(P1) where P < P1.
nonexecutable deliver(P) & deliver(P1) where P < P1.
nonexecutable pickup(P) & deliver(P1).

% A request makes a package wait at its origin for the robot.
request(P,O) causes phase(P)=waiting & origin(P)=O.
address(P,O) causes dest(P)=O.

% A cancellation drops a package that is still waiting (the request is gone); a package
% already on board (or picked up during the same step) goes back to its origin.
cancel(P) causes phase(P)=idle & origin(P)=none & dest(P)=none if phase(P)=waiting & -pickup(P).
cancel(P) causes dest(P)=O if phase(P)=carried & origin(P)=O & -deliver(P).
cancel(P) causes dest(P)=O if phase(P)=waiting & origin(P)=O & pickup(P).
